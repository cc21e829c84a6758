"""An LWPR model as arrays, for snapshots: each receptive field is one flat float64 row.

The row is the layout the kernels computed on before the model became compiled structures
(issue 32), kept so that snapshots load in either version: two scalars (beta0, sum_e2) and two
spare slots; the n-vectors of lwpr_model.FIELD_VECTORS in order (but the exact fit's
coefficients); its n-by-n matrices, row-major (but the exact fit's inverse); then the exact fit's
n + 1 coefficients and its (n + 1)-square inverse. A snapshot holds the rows (outputs, fields,
floats; an output with fewer fields than the most has rows of zeros after its own), each field's
projection count (outputs, fields) and each output's field count.
"""
from __future__ import annotations

import numba as nb
import numpy as np

from .lwpr_model import blank_field, copy_into

N_SCALARS, N_VECTORS, N_MATRICES = 4, 13, 9


@nb.njit(cache=True)
def floats_per_rf(n):
    """Length of one receptive field's row for n inputs."""
    return N_SCALARS + N_VECTORS * n + N_MATRICES * n * n + (n + 1) * (n + 2)


def check_rows(rows: np.ndarray, n_reg: np.ndarray, counts: np.ndarray, n_in: int, n_out: int) -> None:
    """ValueError unless the arrays are a snapshot's fields for n_in inputs and n_out outputs."""
    slots = rows.shape[1] if rows.ndim == 3 else -1
    if rows.shape != (n_out, slots, floats_per_rf(n_in)) or n_reg.shape != (n_out, slots) or counts.shape != (n_out,):
        raise ValueError(f"LWPR snapshot arrays of shapes {rows.shape}, {n_reg.shape}, {counts.shape} do not hold "
                         f"receptive fields of {n_in} inputs for {n_out} outputs")
    if ((counts < 0) | (counts > slots)).any():
        raise ValueError(f"LWPR snapshot field counts {counts.tolist()} do not fit its {slots} rows per output")
    in_use = np.arange(slots)[None, :] < counts[:, None]
    if ((n_reg < 1) | (n_reg > n_in))[in_use].any():
        raise ValueError(f"LWPR snapshot projection counts must lie in 1..{n_in}")


@nb.njit(cache=True)
def _vectors(rf):
    return (rf.centre, rf.mean_x, rf.var_x, rf.beta, rf.ss_s2, rf.ss_yres, rf.sum_e_cv2, rf.sum_w, rf.n_data,
            rf.lam, rf.h_trace, rf.r_trace, rf.s_last)


@nb.njit(cache=True)
def _matrices(rf):
    return rf.M, rf.D, rf.alpha, rf.meta_b, rf.meta_h, rf.U, rf.P, rf.ss_xres_yres, rf.ss_xres


@nb.njit(cache=True)
def pack(model):
    """(rows, projection counts, field counts) of the model's fields, as many rows per output as the most."""
    n, n_out = model.n_in, len(model.outputs)
    counts = np.zeros(n_out, dtype=np.int64)
    slots = 1
    for k in range(n_out):
        counts[k] = len(model.outputs[k])
        slots = max(slots, counts[k])
    rows = np.zeros((n_out, slots, floats_per_rf(n)))
    n_reg = np.zeros((n_out, slots), dtype=np.int64)
    for k in range(n_out):
        for j in range(counts[k]):
            rf = model.outputs[k][j]
            row = rows[k, j]
            row[0], row[1] = rf.beta0, rf.sum_e2
            at = N_SCALARS
            for values in _vectors(rf):
                copy_into(row, values, at)
                at += n
            for values in _matrices(rf):
                copy_into(row, values, at)
                at += n * n
            copy_into(row, rf.rls_theta, at)
            copy_into(row, rf.rls_inverse, at + n + 1)
            n_reg[k, j] = rf.n_reg
    return rows, n_reg, counts


@nb.njit(cache=True)
def unpack(model, rows, n_reg, counts):
    """Append the fields of `pack`'s arrays (checked by check_rows) to the model's outputs."""
    n = model.n_in
    for k in range(len(model.outputs)):
        for j in range(counts[k]):
            rf = blank_field(n)
            row = rows[k, j]
            rf.beta0, rf.sum_e2 = row[0], row[1]
            at = N_SCALARS
            for values in _vectors(rf):
                copy_into(values, row[at:at + n])
                at += n
            for values in _matrices(rf):
                copy_into(values, row[at:at + n * n])
                at += n * n
            copy_into(rf.rls_theta, row[at:at + n + 1])
            copy_into(rf.rls_inverse, row[at + n + 1:])
            rf.n_reg = n_reg[k, j]
            model.outputs[k].append(rf)
