"""The floor of the loop benchmark: a raw UDP round trip between two processes on loopback."""
from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # the repository: rigs.*, benchmarks.*
import services  # noqa: E402,F401  (first: one BLAS thread per process, see services/__init__.py)

import socket
import time

import numpy as np


def echo(port: int, seconds: float) -> None:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", port))
        s.settimeout(0.5)
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            try:
                data, addr = s.recvfrom(2048)
            except TimeoutError:
                continue
            s.sendto(data, addr)


def round_trips(port: int, count: int, payload: bytes) -> np.ndarray:
    out = np.empty(count)
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.settimeout(1.0)
        for i in range(count):
            t0 = time.perf_counter()
            s.sendto(payload, ("127.0.0.1", port))
            s.recvfrom(2048)
            out[i] = time.perf_counter() - t0
    return out


if __name__ == "__main__":
    echo(int(sys.argv[1]), float(sys.argv[2]))
