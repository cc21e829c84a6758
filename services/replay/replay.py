"""Retrain learners on a recorded run's training pairs, in their recorded order, and evaluate each on every
recorded input (the paper's section VI: compare learning algorithms on the same experience, freed from
real time).

Each input is answered after the pairs the live learner had learned when it answered that tick (its
proposals say how many), or, where no live learner answered, after the pairs of earlier ticks; so the
live learner's own class, parameters and seed reproduce its recorded answers; and the ticks it answered while
it had pairs taken in and not yet learned, which the learner service answers unsure whatever its model says
(services/boxes/learner.py), are answered so (`catching_up`, `as_served`).
"""
from __future__ import annotations

import time
from dataclasses import dataclass, replace

import numpy as np

from services.arbitration.algorithm2 import learn_pair
from services.learners import compile_kernels, make_learner, parse_learner_spec
from services.params import parse_params
from services.recording.runs import RecordedRun


@dataclass
class Replayed:
    spec: str
    y: np.ndarray           # (n, n_out) its answer to every recorded input
    confidence: np.ndarray  # (n,)
    learn_s: float          # time spent learning
    predict_s: float
    updates: int
    size: int


def learner_from_spec(spec: str, n_in: int, n_out: int, seed: int):
    name, flags = parse_learner_spec(spec)
    return make_learner(name, n_in, n_out, seed=seed, **parse_params(flags[1::2]))


def schedule(run: RecordedRun, live: str | None = None) -> np.ndarray:
    """Per recorded input, how many pairs are learned before it is answered: the pairs of earlier ticks,
    or, given a live learner, what it had learned when it answered that tick (carried over the ticks it
    did not answer; before its first answer, no more than it had then)."""
    counts = run.pairs_before()
    if live in run.live:
        inputs, answers = run.answered(live)
        learned = run.live[live].learned[answers]
        ok = learned >= 0
        if ok.any():
            known = np.full(len(run.ticks), -1)
            known[inputs[ok]] = np.minimum(learned[ok], len(run.pair_ticks))
            last = np.maximum.accumulate(np.where(known >= 0, np.arange(len(known)), -1))
            first = known[last[last >= 0][0]]
            counts = np.where(last >= 0, known[last.clip(0)], np.minimum(counts, first))
    return np.maximum.accumulate(counts)


def catching_up(run: RecordedRun, live: str | None) -> np.ndarray:
    """Per recorded input, whether live learner `live` answered it with pairs taken in and not yet learned (its
    proposals say how many): the service answers those unsure. False where it did not answer, or none is given."""
    unsure = np.zeros(len(run.ticks), dtype=bool)
    if live in run.live:
        inputs, answers = run.answered(live)
        unsure[inputs] = run.live[live].backlog[answers] > 0
    return unsure


def as_served(result: Replayed, unsure: np.ndarray) -> Replayed:
    """`result` as the learner service would have answered: unsure (confidence 0) on the inputs `unsure` marks."""
    return replace(result, confidence=np.where(unsure, 0.0, result.confidence))


def replay(run: RecordedRun, spec: str, seed: int = 0, plan: np.ndarray | None = None,
           quasi_batch: bool = False, progress=None) -> Replayed:
    """`spec` trained on the run's pairs and answering every input after `plan[i]` pairs (default:
    `schedule(run)`). quasi_batch: not online; refit from scratch on every pair so far at the end of
    each teaching span (the paper's proposal), answering in between with the last fit."""
    plan = schedule(run) if plan is None else plan
    n_in, n_out = run.spaces.input.dims, run.spaces.output.dims
    model = learner_from_spec(spec, n_in, n_out, seed)
    compile_kernels(model)  # as the live learner does before it serves: compiling is not learning
    if quasi_batch:
        return replay_quasi_batch(run, spec, seed, plan, model, progress)
    answers, learn_s, predict_s, learned = learn_and_answer(
        model, run.x, (run.pair_x, run.pair_y, run.pair_mask, run.pair_sources), plan, lambda m, x: m.predict_one(x),
        progress)
    ys = run.spaces.output.clip(np.array([p.y for p in answers]).reshape(len(run.ticks), n_out))
    confidence = np.array([p.confidence for p in answers], dtype=np.float64)
    return Replayed(spec, ys, confidence, learn_s, predict_s, learned, int(model.size))


def learn_and_answer(model, x: np.ndarray, pairs: tuple, plan: np.ndarray, answer, progress=None) -> tuple:
    """Each input x[i] answered, `answer(model, x[i])`, once the first plan[i] of `pairs` (xs, ys, masks) are
    learned, in order (each told who taught it, `sources`, where the learner tells teachers apart); returns the
    answers, the seconds spent learning and answering, and the pairs learned."""
    pair_x, pair_y, pair_mask, pair_sources = pairs
    answers, learned, learn_s, predict_s = [], 0, 0.0, 0.0
    for i, xi in enumerate(x):
        start = time.perf_counter()
        while learned < plan[i]:
            learn_pair(model, pair_x[learned], pair_y[learned], pair_mask[learned], str(pair_sources[learned]))
            learned += 1
        middle = time.perf_counter()
        answers.append(answer(model, xi))
        predict_s += time.perf_counter() - middle
        learn_s += middle - start
        if progress is not None:
            progress(1)
    return answers, learn_s, predict_s, learned


def replay_quasi_batch(run: RecordedRun, spec: str, seed: int, plan: np.ndarray, model, progress=None) -> Replayed:
    """Refit from scratch on every pair so far at the end of each teaching span, answering in between with the
    last fit."""
    n_in, n_out = run.spaces.input.dims, run.spaces.output.dims
    ys, confidence = np.empty((len(run.ticks), n_out)), np.empty(len(run.ticks))
    fitted_upto, learn_s, predict_s = 0, 0.0, 0.0
    for i, x in enumerate(run.x):
        start = time.perf_counter()
        if span_ended(run, i) and plan[i] > fitted_upto:
            model, fitted_upto = learner_from_spec(spec, n_in, n_out, seed), int(plan[i])
            learn_pairs(model, run, slice(0, fitted_upto))
        middle = time.perf_counter()
        p = model.predict_one(x)
        ys[i], confidence[i] = run.spaces.output.clip(p.y), p.confidence
        predict_s += time.perf_counter() - middle
        learn_s += middle - start
        if progress is not None:
            progress(1)
    return Replayed(spec, ys, confidence, learn_s, predict_s, fitted_upto, int(model.size))


def span_ended(run: RecordedRun, i: int) -> bool:
    """Whether input i is the first after a teaching span (the teacher drove the tick before, not this)."""
    return i > 0 and run.modes[i - 1] == "teacher" and run.modes[i] != "teacher"


def learn_pairs(model, run: RecordedRun, rows) -> int:
    """The pairs `rows` picks (a slice or row numbers, in order) in one batch (per pair where some are partial),
    each told who taught it where the learner tells teachers apart; returns how many."""
    xs, ys, masks, sources = run.pair_x[rows], run.pair_y[rows], run.pair_mask[rows], run.pair_sources[rows]
    if len(xs) and np.all(masks == 1):
        told = {"sources": [str(s) for s in sources]} if getattr(model, "learns_sources", False) else {}
        model.learn_many(xs, ys, **told)
        return len(xs)
    for x, y, mask, source in zip(xs, ys, masks, sources):
        learn_pair(model, x, y, mask, str(source))
    return len(xs)
