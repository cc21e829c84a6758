"""One single-output learner per output, so that a pair can teach some outputs and leave the rest.

A partial teacher (say, the head's pan only) gives a pair whose other outputs are the student's
own guesses; learning those would unlearn what another teacher taught (docs/results.md). With
`learn_one(x, y, mask)` only the outputs where mask is 1 learn. For LWPR, whose receptive fields
are per output anyway, this is the same model; for the others it is n_out models side by side.

Outputs held still share one learner (issue 34): a base learner with `holding` (the GP) taught one
value all along is the same model whatever the value but for the value, so every output taught the
same pairs and never anything but its first value is one learner taught 0.0, and `holding(value)` makes
its own learner, identical to the one it would have been, the moment it is taught something else or
left out of a pair the others learn. The mirror teacher holds 16 of the Aibo's 18 joints: one learner
where there were 16 (their answers and confidences identical, to the last bit but for a batch's taught
mean: docs/learners.md).
"""
from __future__ import annotations

import numpy as np

from .base import Learner, Prediction, Predictions, land_each
from .inputs import as_matrix, as_vector
from .registry import LEARNERS, make_learner, register


class PerOutput(Learner):
    accepts_mask = True
    share_held = True  # outputs held still share one learner, where the base can say `holding` (see above)

    def __init__(self, n_in: int, n_out: int, seed: int = 0, base: str = "lwpr", params: dict | None = None):
        super().__init__(n_in, n_out, seed)
        if base not in LEARNERS or base == "per-output":
            raise ValueError(f"base must be a registered single learner, got {base!r}")
        self.base, self.params = base, dict(params or {})
        # _held: groups of outputs sharing one learner, each {"outputs": [...], "model": learner taught 0.0,
        # "values": what each output was taught}; their _parts are None
        self._held: list[dict] = []
        if self.share_held and hasattr(LEARNERS[base], "holding"):
            self._parts = [None] * n_out
            shared = make_learner(base, n_in, 1, seed=seed, **self.params)
            self._held = [{"outputs": list(range(n_out)), "model": shared, "values": np.zeros(n_out)}]
        else:
            self._parts = [make_learner(base, n_in, 1, seed=seed + i, **self.params) for i in range(n_out)]

    @property
    def learns_sources(self) -> bool:
        """Told who taught each pair where the base learner is (gp: each teacher's own noise)."""
        return bool(getattr(LEARNERS[self.base], "learns_sources", False))

    def __setstate__(self, state: dict) -> None:
        state.setdefault("_held", [])  # a snapshot from before outputs shared: each its own learner
        super().__setstate__(state)

    # --- outputs held still, sharing a learner --------------------------------------------------------
    def _release(self, group: dict, keep: np.ndarray) -> None:
        """Each output of the group not in `keep` (a mask over its outputs) gets its own learner."""
        model, outputs = group["model"], np.asarray(group["outputs"])
        for j in np.flatnonzero(~keep):
            o = int(outputs[j])
            self._parts[o] = model.holding(float(group["values"][j]), self.seed + o)
        group["outputs"], group["values"] = outputs[keep].tolist(), group["values"][keep]

    def _part_held(self, taught: np.ndarray) -> None:
        """Before a pair that teaches the outputs in `taught`: a group only some of whose outputs it teaches
        becomes two (the untaught a copy of it)."""
        for group in list(self._held):
            inside = taught[group["outputs"]]
            if inside.any() and not inside.all():
                outputs = np.asarray(group["outputs"])
                twin = group["model"].holding(0.0, self.seed)  # a copy: it was taught 0.0
                self._held.append({"outputs": outputs[~inside].tolist(), "model": twin,
                                   "values": group["values"][~inside].copy()})
                group["outputs"], group["values"] = outputs[inside].tolist(), group["values"][inside]

    def _learn_held(self, xs: np.ndarray, ys: np.ndarray, taught: np.ndarray, sources: list | None) -> None:
        """Rows (all taught the `taught` outputs): each group's outputs still held learn as one; those taught
        another value get their own learner first, to learn it with the other parts."""
        self._part_held(taught)
        for group in list(self._held):
            if not taught[group["outputs"][0]]:
                continue
            model, columns = group["model"], ys[:, group["outputs"]]
            if model.n_learned == 0:
                group["values"] = columns[0].copy()
            self._release(group, np.all(columns == group["values"], axis=0))
            if not group["outputs"]:
                self._held.remove(group)
            elif len(xs) == 1:
                model.learn_one(xs[0], np.zeros(1), **({} if sources is None else {"source": sources[0]}))
            else:
                model.learn_many(xs, np.zeros((len(xs), 1)), **({} if sources is None else {"sources": sources}))

    # --- the contract -------------------------------------------------------------------------------
    def learn_one(self, x, y, mask=None, source: str | None = None) -> None:
        x = as_vector(x, self.n_in, "inputs")
        y = as_vector(y, self.n_out, "outputs")
        taught = np.ones(self.n_out, dtype=bool) if mask is None else as_vector(mask, self.n_out, "mask values") != 0
        told = {} if source is None else {"source": self._checked_source(source)}
        if self._held:
            self._learn_held(x[None, :], y[None, :], taught, None if source is None else [told["source"]])
        for i in np.flatnonzero(taught):
            if self._parts[i] is not None:
                self._parts[i].learn_one(x, y[i:i + 1], **told)
        self._n_learned += 1

    def learn_many(self, xs, ys, sources=None) -> None:
        """Each part learns its output's column by its own batch path. As in learn_one, the taught ranges,
        the inputs shown and the taught mean are the parts' (they hold and fade their own answers); this
        one's stay unlearned, as a pair learned one at a time leaves them."""
        xs = as_matrix(xs, self.n_in, "inputs")
        ys = as_matrix(ys, self.n_out, "outputs", rows=xs.shape[0])
        if sources is not None:
            sources = [self._checked_source(source) for source in sources]
            if len(sources) != len(xs):
                raise ValueError(f"sources must name the teacher of each of the {len(xs)} rows, got {len(sources)}")
        told = {} if sources is None else {"sources": sources}
        if self._held and len(xs):
            self._learn_held(xs, ys, np.ones(self.n_out, dtype=bool), sources)
        for i, part in enumerate(self._parts):
            if part is not None:
                part.learn_many(xs, ys[:, i:i + 1], **told)
        self._n_learned += xs.shape[0]

    def predict_one(self, x) -> Prediction:
        y, _, taught = self._answer(as_vector(x, self.n_in, "inputs"), None)
        return Prediction(y, float(min(taught)) if taught else 0.0)

    def answers(self, x, outputs=None) -> tuple[np.ndarray, np.ndarray]:
        """Each output's answer and the confidence of the learner answering it (NaN: that learner has learned
        nothing); only `outputs` asked where given (the rest 0.0 and NaN). The least of these is predict_one's
        confidence: replay.side_by_side gathers them from processes that each learned some outputs."""
        asked = None
        if outputs is not None:
            asked = np.zeros(self.n_out, dtype=bool)
            asked[outputs] = True
        y, confidence, _ = self._answer(as_vector(x, self.n_in, "inputs"), asked)
        return y, confidence

    def _answer(self, x: np.ndarray, asked: np.ndarray | None) -> tuple[np.ndarray, np.ndarray, list[float]]:
        """The outputs' answers (`asked`: a mask of those wanted, None for all), each output's learner's
        confidence (NaN where not asked or it learned nothing), and those confidences, one per learner."""
        y, confidence, taught = np.zeros(self.n_out), np.full(self.n_out, np.nan), []  # never taught: 0, unasked
        if self._n_learned == 0:
            return y, confidence, taught
        for i, part in enumerate(self._parts):
            if part is not None and (asked is None or asked[i]) and part.n_learned > 0:
                a = part.predict_one(x)  # each part's own fast path
                y[i], confidence[i] = a.y[0], a.confidence
                taught.append(a.confidence)
        for group in self._held:
            model, members = group["model"], group["outputs"]
            if model.n_learned > 0 and (asked is None or asked[members].any()):
                a = model.predict_one(x)
                # the shared learner answers 0.0, which each output reads as its own value
                y[members], confidence[members] = group["values"] + a.y[0], a.confidence
                taught.append(a.confidence)
        return y, confidence, taught

    def _predict_many(self, xs: np.ndarray) -> Predictions:
        y, taught = np.empty((len(xs), self.n_out)), []
        # the least supported taught output decides how sure the student is; an output no teacher
        # ever spoke for is nobody's lesson (a pan-only teacher would otherwise leave it unsure for ever)
        for i, part in enumerate(self._parts):
            if part is not None:
                a = part.predict_many(xs)
                y[:, i] = a.y[:, 0]
                if part.n_learned > 0:
                    taught.append(a.confidence)
        for group in self._held:
            model = group["model"]
            a = model.predict_many(xs)
            y[:, group["outputs"]] = group["values"] + a.y if model.n_learned > 0 else a.y
            if model.n_learned > 0:
                taught.append(a.confidence)
        confidence = np.min(np.vstack(taught), axis=0) if taught else np.zeros(len(xs))
        return Predictions(y, confidence)

    def _learners(self) -> list:
        return [part for part in self._parts if part is not None] + [group["model"] for group in self._held]

    def serve_live(self) -> None:
        for part in self._learners():
            part.serve_live()

    def warm_served(self) -> None:
        for part in self._learners():
            part.warm_served()

    def land_upkeep(self, budget_s: float) -> int:
        return land_each(self._learners, budget_s)

    @property
    def upkeep_under_way(self) -> int:
        return sum(part.upkeep_under_way for part in self._learners())

    def _bound(self, y: np.ndarray) -> np.ndarray:
        return y  # each part holds its own answers

    def _fades(self) -> bool:
        return False  # and fades them beyond what it was shown

    @property
    def n_broken(self) -> int:
        held = sum(group["model"].n_broken * len(group["outputs"]) for group in self._held)
        return self._n_broken + held + sum(part.n_broken for part in self._parts if part is not None)

    @property
    def size(self) -> int:
        """Samples remembered, over every output (each output of a shared learner counted)."""
        return self.size_of(range(self.n_out))

    def size_of(self, outputs) -> int:
        """Samples remembered by the learners answering `outputs`, a shared learner counted once per output."""
        shared = {o: group["model"].size for group in self._held for o in group["outputs"]}
        return int(sum(shared[o] if self._parts[o] is None else self._parts[o].size for o in outputs))

    def part(self, output: int) -> Learner:
        """The learner of one output (a copy holding its value, where it shares one with other outputs)."""
        if self._parts[output] is not None:
            return self._parts[output]
        group = next(g for g in self._held if output in g["outputs"])
        return group["model"].holding(float(group["values"][group["outputs"].index(output)]), self.seed + output)

    @classmethod
    def _unit_test_params(cls) -> dict:
        return {"base": "knn", "params": {"max_points": 300}}


register("per-output", PerOutput)
