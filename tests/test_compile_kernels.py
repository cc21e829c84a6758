"""compile_kernels (run by the learner service before it says it is ready) builds every compiled kernel the learner
will use: afterwards, learning and answering for a while, one answer beyond what was shown, a batch, the size, and a
snapshot taken and restored (what a swap asks of a learner while it serves) add no signature to any of the learners'
kernels. Each learner in a process of its own, where nothing was compiled or loaded before. Without the snapshot in
compile_kernels, LWPR's first snapshot compiled (or loaded) four kernels on the answer path: 2.4 s with numba's cache
empty."""
import json
import subprocess
import sys

import pytest

from rigs.harness import REPO
from services.learners import LEARNERS

pytestmark = pytest.mark.live

PROBE = """
import importlib, json, pkgutil, sys
import numba
import numpy as np
import services
import services.learners as package
from services.learners import compile_kernels, make_learner

modules = [importlib.import_module(f"services.learners.{m.name}") for m in pkgutil.iter_modules(package.__path__)]
def signatures():
    return {f"{m.__name__}.{k}": len(v.signatures) for m in modules for k, v in vars(m).items()
            if isinstance(v, numba.core.registry.CPUDispatcher)}

model = make_learner(sys.argv[1], 4, 2, **json.loads(sys.argv[2]))
compile_kernels(model)
if sys.argv[3] == "served":
    model.serve_live()
before = signatures()
rng = np.random.default_rng(1)
for _ in range(200):
    model.predict_one(rng.uniform(-1, 1, 4))
    model.learn_one(rng.uniform(-1, 1, 4), rng.uniform(-1, 1, 2))
for _ in range(3):  # as a payload's arrays come: read-only (np.frombuffer), and a strided view
    x, y = np.frombuffer(rng.uniform(-1, 1, 4).tobytes()), np.frombuffer(rng.uniform(-1, 1, 2).tobytes())
    model.predict_one(x)
    model.learn_one(x, y)
    model.learn_one(rng.uniform(-1, 1, (4, 2))[:, 0], rng.uniform(-1, 1, (2, 2))[:, 1])
model.predict_one(np.full(4, 3.0))
model.predict_many(np.zeros((3, 4)))
model.size
type(model).restore(model.snapshot())
after = signatures()
print(json.dumps({"kernels": len(after), "new": {k: v for k, v in after.items() if v != before.get(k, 0)}}))
"""


@pytest.mark.parametrize("name,params,how", [(name, {}, "offline") for name in sorted(LEARNERS)] + [
    ("gp", {}, "served"), ("per-output", {"base": "gp"}, "served")])  # the deploy profiles' learners, as they serve
def test_after_compile_kernels_serving_and_a_swaps_snapshot_compile_nothing_more(name, params, how):
    out = subprocess.run([sys.executable, "-c", PROBE, name, json.dumps(params), how], cwd=REPO, capture_output=True,
                         text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    found = json.loads(out.stdout.strip().splitlines()[-1])
    assert found["kernels"] > 0, "no compiled kernel found to watch"
    assert found["new"] == {}, f"{name}: compiled after compile_kernels: {found['new']}"
