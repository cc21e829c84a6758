"""dogged's services.

One BLAS thread per process, set here, before any of them loads numpy: every service is one process
among many on the robot's machine, and OpenBLAS's own threads fight them for the cores. Measured on
the 2-core machine: a GP hyper-parameter fit on 256 samples took 1.44 s with OpenBLAS's default
threads and 0.25 s with one (128 samples: 1.29 s and 0.07 s). Set the variables to override.

And the C allocator's thresholds fixed where a GP's fits want them (services/allocator.py), and the
process on the CPUs its supervisor gave it (services/placement.py), while it has no thread but this one.
"""
import os

for _variable in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

from services.allocator import fix_thresholds  # noqa: E402

fix_thresholds()

from services.placement import take_own_cpus  # noqa: E402

take_own_cpus()
