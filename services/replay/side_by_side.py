"""A per-output learner replayed in processes side by side (issue 34).

Its outputs' learners never share what they learn: a pair teaches each output on its own, and outputs held still
share one learner that is the very one each would have had (learners/per_output.py). So a process that learns the
run's pairs for some outputs only (the others masked out) answers those outputs as the single process would, to
the last bit (tests/test_replay_side_by_side.py); the answers gathered, each input's confidence is the least of
its outputs', as `PerOutput.predict_one` takes it.

Each output taught more than one value gets a process, the outputs held still one more: more processes than
cores where there are few, and the system shares the cores out (mirroring's held learner costs an eighth of a
taught output's, and finishes early). Processes are spawned, never forked: the caller may hold a Zenoh session.
Jobs and results travel as pickles between this process and its own children only, never over the bus: the
recording was decoded and checked by its reader before any job is made.
"""
from __future__ import annotations

import multiprocessing
import os
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from services.learners import compile_kernels, parse_learner_spec
from services.recording.runs import RecordedRun
from services.replay.replay import Replayed, learn_and_answer, learner_from_spec, replay, schedule

READY_TIMEOUT_S = 120.0  # a spawned process imports numpy, scipy and the learner's compiled kernels


@dataclass(frozen=True)
class Job:
    """What one process replays: the run's inputs and pairs, the schedule, and the outputs it answers."""
    seed: int
    outputs: list[int]
    x: np.ndarray
    pair_x: np.ndarray
    pair_y: np.ndarray
    pair_mask: np.ndarray
    plan: np.ndarray
    pair_sources: np.ndarray  # who taught each pair


def output_bins(run: RecordedRun, spec: str, most: int | None = None) -> list[list[int]]:
    """The outputs of a per-output `spec` in the groups processes replay (at most `most`, twice the cores by
    default), or [] where side by side does not pay: another learner, or one group. Each output taught more
    than one value is a group of its own; every other output one more, together."""
    if parse_learner_spec(spec)[0] != "per-output":
        return []
    taught = run.pair_mask != 0
    n_out = run.spaces.output.dims
    varying = [o for o in range(n_out) if taught[:, o].any() and np.ptp(run.pair_y[taught[:, o], o]) > 0]
    still = [o for o in range(n_out) if o not in varying]
    groups = [[o] for o in varying] + ([still] if still else [])
    bins = groups[:most or 2 * (os.cpu_count() or 1)]
    for i, group in enumerate(groups[len(bins):]):  # past the cap: dealt out in turn
        bins[i % len(bins)] = sorted(bins[i % len(bins)] + group)
    return bins if len(bins) > 1 else []


class ReplayWorkers:
    """`count` processes, ready (modules imported, the learner's kernels compiled) once made; each replays a Job
    with learner `spec`. A context manager: the processes end with it."""

    def __init__(self, count: int, spec: str, n_in: int, n_out: int):
        context = multiprocessing.get_context("spawn")
        self._pipes, self._processes = [], []
        try:
            for _ in range(count):
                here, there = context.Pipe()
                process = context.Process(target=_serve, args=(there, spec, n_in, n_out), daemon=True)
                process.start()
                there.close()
                self._pipes.append(here)
                self._processes.append(process)
            for pipe in self._pipes:
                self._receive(pipe, READY_TIMEOUT_S)
        except BaseException:
            self.close()
            raise

    def run(self, jobs: list[Job]) -> list[tuple]:
        """Each job in a process of its own (no more jobs than processes); their results in order."""
        if len(jobs) > len(self._pipes):
            raise ValueError(f"{len(jobs)} jobs for {len(self._pipes)} processes")
        for pipe, job in zip(self._pipes, jobs):
            pipe.send(job)
        return [self._receive(pipe, None) for pipe in self._pipes[:len(jobs)]]

    @staticmethod
    def _receive(pipe, timeout: float | None):
        if timeout is not None and not pipe.poll(timeout):
            raise RuntimeError(f"a replay process was not ready within {timeout:.0f} s")
        try:
            kind, value = pipe.recv()
        except EOFError as err:
            raise RuntimeError("a replay process ended without an answer") from err
        if kind == "error":
            raise RuntimeError(f"a replay process failed: {value}")
        return value

    def close(self) -> None:
        for pipe in self._pipes:
            try:
                pipe.send(None)
            except OSError:
                pass  # already gone
            pipe.close()
        for process in self._processes:
            process.join(timeout=5)
            if process.is_alive():
                process.kill()
                process.join()
        self._pipes, self._processes = [], []

    def __enter__(self) -> ReplayWorkers:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def _serve(pipe, spec: str, n_in: int, n_out: int) -> None:
    """A replay process: compile the learner's kernels, say ready, then replay each Job sent until None."""
    try:
        compile_kernels(learner_from_spec(spec, n_in, n_out, 0))
        pipe.send(("ready", None))
        while (job := pipe.recv()) is not None:
            pipe.send(("done", replay_outputs(job, spec, n_in, n_out)))
    except (EOFError, KeyboardInterrupt):
        return  # the caller is gone
    except Exception as err:  # noqa: BLE001 - told to the caller, which raises it
        pipe.send(("error", f"{type(err).__name__}: {err}"))


class OutputsReplayed(NamedTuple):
    """One process's share: its outputs' answers (n, k), the confidence of each one's learner (n, k; NaN where it
    had learned nothing), what those learners remember, the seconds learning and answering, and pairs learned."""
    y: np.ndarray
    confidence: np.ndarray
    size: int
    learn_s: float
    predict_s: float
    updates: int


def replay_outputs(job: Job, spec: str, n_in: int, n_out: int) -> OutputsReplayed:
    """The learner taught only the job's outputs (the others masked out of every pair), answering those."""
    model = learner_from_spec(spec, n_in, n_out, job.seed)
    keep = np.zeros(n_out)
    keep[job.outputs] = 1.0
    answers, learn_s, predict_s, learned = learn_and_answer(
        model, job.x, (job.pair_x, job.pair_y, job.pair_mask * keep, job.pair_sources), job.plan,
        lambda m, x: m.answers(x, job.outputs))
    y = np.array([a[0][job.outputs] for a in answers]).reshape(len(job.x), len(job.outputs))
    confidence = np.array([a[1][job.outputs] for a in answers]).reshape(y.shape)
    return OutputsReplayed(y, confidence, model.size_of(job.outputs), learn_s, predict_s, learned)


def replay_side_by_side(run: RecordedRun, spec: str, seed: int, plan: np.ndarray, workers: ReplayWorkers,
                        bins: list[list[int]]) -> Replayed:
    """As replay.replay(run, spec, seed, plan), each bin of outputs in one of `workers`. Its learn_s and
    predict_s are the slowest process's."""
    jobs = [Job(seed, outputs, run.x, run.pair_x, run.pair_y, run.pair_mask, plan, run.pair_sources)
            for outputs in bins]
    parts: list[OutputsReplayed] = workers.run(jobs)
    n_out = run.spaces.output.dims
    y, confidence = np.zeros((len(run.ticks), n_out)), np.full((len(run.ticks), n_out), np.nan)
    for outputs, part in zip(bins, parts):
        y[:, outputs], confidence[:, outputs] = part.y, part.confidence
    answered = ~np.isnan(confidence)
    least = np.where(answered.any(1), np.min(np.where(answered, confidence, np.inf), axis=1), 0.0)
    return Replayed(spec, run.spaces.output.clip(y), least, max(p.learn_s for p in parts),
                    max(p.predict_s for p in parts), parts[0].updates, sum(p.size for p in parts))


def replay_any(run: RecordedRun, spec: str, seed: int = 0, plan: np.ndarray | None = None,
               quasi_batch: bool = False, progress=None) -> Replayed:
    """replay.replay, side by side where output_bins says it pays (processes started here and ended after)."""
    bins = [] if quasi_batch else output_bins(run, spec)
    if not bins:
        return replay(run, spec, seed, plan, quasi_batch, progress)
    plan = schedule(run) if plan is None else plan
    with ReplayWorkers(len(bins), spec, run.spaces.input.dims, run.spaces.output.dims) as workers:
        result = replay_side_by_side(run, spec, seed, plan, workers, bins)
    if progress is not None:
        progress(len(run.ticks))
    return result
