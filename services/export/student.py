"""The student of a recorded run as a file: a learner of the live learner's class, hyper-parameters and
seed learns every training pair the run recorded, in the order the live one learned them, and is saved
with the spaces (services.learners.student). So the file answers as the live learner did once it had
learned them all: to the last bit for a learner whose answers depend on its pairs only (LWPR, kNN, SOGP);
the GP's fits run on their own thread live, so its answers also depend on when each fit landed."""
from __future__ import annotations

import ast
import inspect
from pathlib import Path

from bus_schema import InstanceKeys, SchemaError
from services.arbitration.algorithm2 import learn_pair
from services.export.ticks import ExportError
from services.learners import LEARNERS, make_learner, save_student
from services.recording.reader import iter_samples
from services.recording.runs import RecordedRun
from services.replay.replay import learner_from_spec


def live_learner(run: RecordedRun, live: str | None) -> str:
    if live is None:
        if len(run.live) != 1:
            raise ExportError(f"the run has {len(run.live)} live learners ({', '.join(sorted(run.live)) or 'none'}): "
                              "say which with --live")
        return next(iter(run.live))
    if live not in run.live:
        raise ExportError(f"no live learner {live!r} in the run (recorded: {', '.join(sorted(run.live)) or 'none'})")
    return live


def recorded_spec(path: str | Path, instance: str, live: str) -> tuple[str, dict]:
    """(registry name, hyper-parameters) of a live learner, as its last recorded status says them."""
    key = InstanceKeys(instance).status("learner", live)
    state = None
    for sample in iter_samples(path, {key}):
        try:
            state = sample.decoded().state
        except SchemaError:
            continue
    if not state:
        raise ExportError(f"no status of learner {live!r} recorded, so not its class: say it with --learner")
    names = {cls.__name__: name for name, cls in LEARNERS.items()}
    name = names.get(state.get("learner"))
    if name is None:
        raise ExportError(f"learner {live!r} was a {state.get('learner')!r}, not a registered learner: "
                          "say which with --learner")
    return name, _params(LEARNERS[name], state.get("params", {}))


def _params(cls: type, recorded: dict) -> dict:
    """The status says plain values as they are and others by their repr: a repr of the default is the
    default; another is read back as a Python literal."""
    defaults = {p.name: p.default for p in inspect.signature(cls.__init__).parameters.values()}
    params = {}
    for name, value in recorded.items():
        default = defaults.get(name)
        if isinstance(value, str) and not isinstance(default, str):
            if value == repr(default):
                value = default
            else:
                try:
                    value = ast.literal_eval(value)
                except (ValueError, SyntaxError):
                    raise ExportError(f"hyper-parameter {name}={value} of the live learner cannot be read back: "
                                      "say the learner with --learner") from None
        params[name] = value
    return params


def export_student(path: str | Path, run: RecordedRun, out: Path, live: str | None = None, spec: str | None = None,
                   seed: int = 0):
    """Writes the student file; returns the learner it holds."""
    name = live_learner(run, live)
    n_in, n_out = run.spaces.input.dims, run.spaces.output.dims
    if spec:
        model = learner_from_spec(spec, n_in, n_out, seed)
    else:
        learner, params = recorded_spec(path, run.instance, name)
        model = make_learner(learner, n_in, n_out, seed=seed, **params)
    for x, y, mask in zip(run.pair_x, run.pair_y, run.pair_mask):
        learn_pair(model, x, y, mask)
    origin = (f"dogged export {path}: learner {name} of dl/{run.instance} retrained on the {len(run.pair_x)} "
              f"recorded pairs (seed {seed})")
    save_student(out, model, run.spaces, origin)
    return model
