"""The reference LWPR library on the same draws as ours (rigs/lwpr_draws.py).

The library (Klanke, Vijayakumar & Schaal, LGPL; github.com/ipab-slmc/lwpr) is not part of dogged and
not installed by it: `build(source)` compiles benchmarks/reference/lwpr_drive.c against a checkout
of it with gcc. Without one, benchmarks/learners.py prints RECORDED, the figures this module measured
on this 2-core machine (source at ipab-slmc/lwpr 4252d69, gcc -O3).
"""
from __future__ import annotations

import subprocess
import tempfile
from pathlib import Path

import numpy as np

from rigs.lwpr_draws import Case, cross_case, irrelevant_case, mirror_case, samples_until_good
from rigs.tasks import nmse, worst_error
from services.learners.lwpr import default_init_d

DRIVER = Path(__file__).resolve().parents[1] / "reference" / "lwpr_drive.c"
LIBRARY_FILES = ("lwpr.c", "lwpr_aux.c", "lwpr_math.c", "lwpr_mem.c", "lwpr_binio.c")
# settings per protocol: (init_D, w_gen, diag_only, meta, init_alpha); <= 0 keeps the library's default
TUTORIAL = (25.0, 0.2, 0, 1, 250.0)
LIBRARY_DEFAULTS = (-1.0, 0.1, 1, 0, -1.0)  # init_D 25, init_alpha 50, diagonal, no meta-learning


def our_defaults(n_in: int) -> tuple:
    """Our LWPR's defaults (init_D from the input count, meta-learned rates from 250): in 18 or 20 inputs
    the library's init_D 25 makes one field per sample and never learns (worst mirroring error 1.0 after
    2000)."""
    return (default_init_d(n_in), 0.1, 1, 1, 250.0)


MIRROR_EVERY = 250  # the driver predicts after every this many updates

RECORDED = {  # measure(binary, 10) on this machine: draws 0-9 as lwpr_draws.py makes them
    "cross": [0.0427, 0.0362, 0.0475, 0.0226, 0.0272, 0.0389, 0.0353, 0.0284, 0.0301, 0.0407],
    "cross_untuned": [0.1333, 0.0986, 0.1122, 0.0823, 0.0837, 0.0941, 0.1009, 0.0626, 0.0950, 0.0784],
    "irrelevant20": [1.0098, 1.0922, 1.0021, 1.0757, 1.0408, 1.0234, 1.0006, 1.0172, 1.0095, 1.0344],
    "mirror": [14500, 17000, 15500, 17250, 18250, 11250, 12500, 16500, 11000, 13250],
}


def missing_files(source: Path) -> list[str]:
    """What a checkout of ipab-slmc/lwpr at `source` lacks for the build ([] if nothing)."""
    needed = [f"src/{name}" for name in LIBRARY_FILES] + ["include/lwpr.h"]
    return [name for name in needed if not (source / name).is_file()]


def build(source: Path, into: Path) -> Path:
    """Compile the driver against the library's checkout at `source`; returns the executable."""
    include = into / "include"
    include.mkdir(parents=True, exist_ok=True)
    (include / "lwpr_config.h").write_text('#include "lwpr_config_def.h"\n#define LIBRARY_API\n')
    binary = into / "lwpr_drive"
    sources = [str(source / "src" / name) for name in LIBRARY_FILES]
    done = subprocess.run(["gcc", "-O3", f"-I{include}", f"-I{source / 'include'}", "-o", str(binary), str(DRIVER),
                           *sources, "-lm"], capture_output=True, text=True)
    if done.returncode != 0:
        raise RuntimeError(f"building the reference LWPR from {source} failed:\n{done.stderr[-2000:]}")
    return binary


def run(binary: Path, case: Case, settings: tuple, every: int | None = None) -> np.ndarray:
    """The test predictions after every `every` updates (default: once, at the end), stacked."""
    n_in, n_out = case.xs.shape[1], case.ys.shape[1]
    with tempfile.TemporaryDirectory() as work:
        train, test, out = (Path(work) / name for name in ("train.bin", "test.bin", "out.bin"))
        np.hstack([case.xs, case.ys]).astype(np.float64).tofile(train)
        case.test.astype(np.float64).tofile(test)
        args = [str(binary), str(n_in), str(n_out), *(str(value) for value in settings), str(train), str(test),
                str(out), str(every or len(case.xs))]
        subprocess.run(args, check=True, capture_output=True)
        return np.fromfile(out).reshape(-1, len(case.test), n_out)


def measure(binary: Path, draws: int, irrelevant_samples: int = 20_000) -> dict[str, list]:
    """Per protocol, the reference's figure on each draw."""
    figures: dict[str, list] = {"cross": [], "cross_untuned": [], "irrelevant20": [], "mirror": []}
    for draw in range(draws):
        case = cross_case(draw)
        figures["cross"].append(nmse(run(binary, case, TUTORIAL)[-1], case.truth))
        figures["cross_untuned"].append(nmse(run(binary, case, LIBRARY_DEFAULTS)[-1], case.truth))
        case = irrelevant_case(draw, irrelevant_samples)
        figures["irrelevant20"].append(nmse(run(binary, case, our_defaults(20))[-1], case.truth))
        case = mirror_case(draw)
        steps = run(binary, case, our_defaults(18), MIRROR_EVERY)
        errors = {MIRROR_EVERY * (i + 1): worst_error(p, case.truth) for i, p in enumerate(steps)}
        figures["mirror"].append(samples_until_good(errors))
    return figures
