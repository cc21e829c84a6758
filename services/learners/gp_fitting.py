"""When a GP leaf (gp_local.LocalGP) refits its hyper-parameters, and where: after `first_fit` samples and
then each time half as many again, early when the teaching surprises the fit or spreads an input further
than the fit saw, with a search for a split (gp_split) at each doubling of what the leaf learned; in the
caller's thread offline (deterministic), in the fitter's and splitter's processes when serving live, each
fit applied at the leaf's next call once done.
"""
from __future__ import annotations

import logging
import multiprocessing
import os
import threading
import time
from concurrent.futures import Executor, ProcessPoolExecutor, ThreadPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from functools import partial

import numpy as np

from services.placement import to_background
from services.priority import become_background_process
from services.waiting import poll

from . import gp_kernels
from .gp_evidence import Hyper
from .gp_factor import Built, Shape, extend, fit_and_build, shape_of
from .gp_split import RELEVANCE_RATIO, fit_and_split

# refit early once the mean squared standardised error of the last taught ticks passes SURPRISED
# (typical errors of two standard deviations), at most every SURPRISE_REFIT_GAP samples, and each
# such refit doubles the wait for the next
SURPRISED, SURPRISE_REFIT_GAP = 4.0, 8
# and once an input's spread grows past SPREAD_GROWTH times what the last fit saw: the teaching now
# spans a direction the fit hardly knew (an input that never varied starts to: the orange ball)
SPREAD_GROWTH = 2.0
# the largest noise sd a fit may find, as a share of `near` of the taught span, unless `noise_ceiling` says (as
# a share of the span itself): the teacher is assumed right, so teaching that varies by more than that where the
# inputs hardly do is a map to learn (a switch, a sharp turn), not noise to average away: left free, fits of a
# pendulum's swing-up called a third of the teaching noise and the student stopped catching the pendulum
NOISE_SHARE_OF_NEAR = 0.5
MIN_SPLIT_SAMPLES = 64  # remembered, before a leaf weighs a split (and 8 per input): fewer fit noisily

_POOLS: dict[str, Executor] = {}
PARENT_POLL_S = 0.5  # how often a fitting process checks that the learner's process is still there


def _pool(name: str) -> Executor:
    """A process of its own (spawned: nothing forks after a Zenoh session is open) for every GP of the process
    that serves live: fits queue rather than crowd the cores. On a thread of the learner's process (until issue
    34), a fit's Python held the GIL the answer path waited for: the mirroring student, taught live, spent
    0.83 ms a tick answering and 1.34 ms learning where a fit in a process of its own left 0.22 and 1.02 (its
    own CPU a tick 0.80 and 0.74 ms; benchmarks/lib/learner_costs.py, one session). A pool whose process died
    is started again; where no process can start (a script without a `__main__` guard, which spawn imports
    again), a thread does the work as before."""
    pool = _POOLS.get(name)
    if pool is None or getattr(pool, "_broken", False):
        pool = _POOLS[name] = ProcessPoolExecutor(max_workers=1, mp_context=multiprocessing.get_context("spawn"),
                                                  initializer=_start_fitting, initargs=(os.getpid(),))
    return pool


def _start_fitting(parent: int) -> None:
    """A fitting process's first act: off the tick path's CPUs (services.placement), taking of the background ones
    what the router, the recorder and the page leave (services.priority), then watch its learner."""
    to_background()
    become_background_process()
    _outlive_not(parent)


def _outlive_not(parent: int) -> None:
    """In a fitting process: exit once the learner's process is gone (killed, its queue's pipe stays open here)."""
    def watch() -> None:
        while os.getppid() == parent:
            time.sleep(PARENT_POLL_S)
        os._exit(0)
    threading.Thread(target=watch, name="gp-fit-parent", daemon=True).start()


def _fitter() -> Executor:
    return _pool("fit")


def _splitter() -> Executor:
    """One more for the search for splits (gp_split: five fits where a refit is one), so that no refit waits
    behind one: under load a correction's refit queued behind searches, and the corrected ball-seeking
    student went on asking about the orange ball (21 % of its ticks, where it had been 0)."""
    return _pool("split")


def _submit(pool, job, *args):
    """pool().submit, on a new pool if the last one broke (its process killed) meanwhile."""
    try:
        return pool().submit(job, *args)
    except BrokenProcessPool:
        return pool().submit(job, *args)


def start_fitting() -> None:
    """Start the fitting processes now (serve_live: at a service's start, not at its first taught tick)."""
    for name in ("fit", "split"):
        try:
            _pool(name).submit(int).result()
        except (BrokenProcessPool, OSError, RuntimeError) as err:
            logging.getLogger(__name__).warning("GP fits on a thread: no process for them (%s)", err)
            _POOLS[name] = ThreadPoolExecutor(max_workers=1, thread_name_prefix=f"gp-{name}")


def stop_fitting(grace_s: float = 1.0) -> None:
    """The service is ending: queued fits are dropped and the fitting processes end now. Left to Python's exit,
    the pools ran every fit still queued first (a per-output GP's 18 leaves' worth): a learner told to stop
    was still fitting 5 s later and was killed (benchmarks/soak.py --quick). What it learned is in its pair
    log, not in a fit under way."""
    pools = list(_POOLS.values())
    _POOLS.clear()
    for pool in pools:
        pool.shutdown(wait=False, cancel_futures=True)
    workers = multiprocessing.active_children()  # the pools' processes: spawned by this one
    for worker in workers:
        worker.terminate()
    # polled, not joined once: the pool's own thread reaps an ended worker too, and until it records that, a join
    # here finds no child left to wait for and takes the worker for running (CI, under load: a fitting process still
    # listed after stop_upkeep, though it had ended, tests/test_gp_fitting_stop.py); one that did not end is killed
    # and reaped, never left a zombie
    def ended():
        return not any(worker.is_alive() for worker in workers)
    if not poll(ended, grace_s, 0.01):
        for worker in workers:
            if worker.is_alive():
                worker.kill()
        poll(ended, grace_s, 0.01)


_FAILED: dict[str, int] = {}  # jobs that raised, by kind, in this process


def failed(job, kind: str) -> bool:
    """Whether a finished job raised (the leaf keeps what it had): logged the first time and at each doubling."""
    err = job.exception()
    if err is None:
        return False
    count = _FAILED[kind] = _FAILED.get(kind, 0) + 1
    if count & (count - 1) == 0:
        logging.getLogger(__name__).warning("a GP %s failed (%d so far; the leaf keeps its last): %s: %s", kind, count,
                                            type(err).__name__, err)
    return True


class Refitting:
    """The fitting schedule of a LocalGP, which holds the memory (_xs, _ys, _m), the taught statistics and
    the kernel's working quantities this sets (_use)."""

    def _fit_when_due(self) -> None:
        """After each sample learned: refit on schedule, or early on surprise or spread."""
        if self._y_count >= self._next_fit and self._pending is None:  # n_learned lags inside learn_many
            self._next_fit += min(max(self._next_fit // 2, 1), self.refit_every)
            if self._factored:
                self._refit()
        elif self._factored and self._y_count - self._last_fit >= SURPRISE_REFIT_GAP:
            if np.any(self._input_sd() > SPREAD_GROWTH * self._fitted_sd):
                self._refit()  # the teaching spans an input further than the fit saw
            elif self._surprise > SURPRISED and self._y_count - self._last_fit >= self._surprise_gap:
                # the teaching contradicts the fit; if refitting does not end that (a mismatch no fit can
                # mend), the next try waits twice as long
                self._surprise_gap = min(2 * self._surprise_gap, self.refit_every)
                self._refit()

    def _weigh_surprise(self, error: np.ndarray, unit_var: float) -> None:
        """Every taught tick tests what the learner would have said: a running mean of the squared
        standardised error (over the least expected output), which a refit resets."""
        taught = self._taught
        z2 = gp_kernels.surprise(error, unit_var, self._hyper.log_sf, self._y_sum_sq, self._y_count, taught.low,
                                 taught.high)
        self._surprise += (z2 - self._surprise) / SURPRISE_REFIT_GAP

    def serve_live(self) -> None:
        """Fit hyper-parameters in another process from now on (a fit takes up to seconds; the loop must
        not wait), applying each at the next call once done. Offline use stays synchronous and
        deterministic."""
        if not self._background:
            start_fitting()
        self._background = True

    @property
    def upkeep_under_way(self) -> int:
        # running: one done is applied at this leaf's next call, before its next answer counts (a leaf the
        # student never visits again holds its done fit for ever)
        return int(self._pending is not None and not self._pending[0].done()) + \
            int(self._searching is not None and not self._searching.done())

    def _refit(self) -> None:
        if self._pending is not None:
            return  # one fit at a time; whatever asked for this one will ask again
        if self._m <= self.n_in:
            return  # fewer samples than inputs cannot tell which inputs matter: the prior's scales stand
        # the teacher is assumed right: what it shows inconsistently beyond the ceiling is to be learned
        share = NOISE_SHARE_OF_NEAR * self.near if self.noise_ceiling is None else self.noise_ceiling
        ceiling = share * self._taught.span
        # served live, a search still under way in the splitter's process leaves the check due for the next fit:
        # consumed unsearched, in lockstep teaching the searches fell so far behind that a pendulum taught
        # 4000 ticks was never split and its student, sure and wrong, scored 0.46 (1.00 offline)
        consider = self.may_split and self._m >= max(MIN_SPLIT_SAMPLES, 8 * self.n_in) and \
            self._y_count >= self._split_check and self._searching is None
        if consider:  # again once the leaf has learned twice as much: a search is five fits
            self._split_check = 2 * self._y_count
        m, repeats = self._m, self._repeats[:self._m].copy()  # (read only, by the fit and by extend)
        sources = self._source[:m].copy()
        job = partial(fit_and_split, self._xs[:m].copy(), self._ys[:m].copy(), self._hyper, self.fit_points,
                      self.relevance_prior_sd, self.noise_floor, self.max_iterations, ceiling, repeats=repeats,
                      sources=sources)
        seen = (self._input_sd(), self._y_count)  # what the fit sees, for the refit triggers
        if not self._background:
            self._adopt(job(consider), seen)
            return
        # the fitter builds the factor too, over the memory as it was, thinned there once full (to what _thin
        # leaves): the answer path extends it by what was taught meanwhile (gp_factor)
        drop = self._to_forget() if m >= self.memory else 0
        memory = (m, self._thins, repeats)
        self._pending = (_submit(_fitter, fit_and_build, job, memory[2], self._born[:m].copy(), drop,
                                 self.noise_floor, sources), seen + (memory,))
        if consider:
            self._searching = _submit(_splitter, job, True)

    def land_upkeep(self, budget_s: float) -> int:
        """A finished fit or search applied now (a split it proposes is left in proposed_split for the tree), and
        the answer's copies of the factor made current: off the answer path (Learner.land_upkeep)."""
        done = [job for job in (self._searching, self._pending and self._pending[0]) if job is not None and job.done()]
        if not done:
            return 0
        self._collect()
        if self._factored and self._background:
            self._ready_to_answer()
        return len(done)

    def _collect(self) -> None:
        """Apply a fit done in the fitter's process (a failed one leaves the last fit in place). If
        teaching went on while it ran, fit again: when teaching stops, the last fit has seen it all."""
        if self._searching is not None and self._searching.done():
            done, self._searching = self._searching, None
            if not failed(done, "search for a split") and done.result()[1] is not None:
                self.proposed_split = done.result()[1]
        if self._pending is not None and self._pending[0].done():
            (done, seen), self._pending = self._pending, None
            if not failed(done, "fit"):
                self._adopt(done.result(), seen)
            if self._y_count > seen[1]:
                self._refit()

    def _adopt(self, found: tuple, seen: tuple) -> None:
        """A fit and, where it was considered, a split its evidence favours (gp_split): the tree applies it."""
        hyper, split = found[:2]
        both = hyper.varied & self._hyper.varied
        flipped = bool(np.any(np.abs(hyper.log_ell - self._hyper.log_ell)[both] >= RELEVANCE_RATIO))
        self._use(hyper, seen[:2], rebuild=len(found) == 2)
        if len(found) == 4:
            self._land(*found[2:], seen[2])
        if split is not None:
            self.proposed_split = split
        elif flipped and self.may_split:
            # what matters changed at once (the pendulum's sine from a length scale of 0.4 to 41 as the swing's
            # samples came to outnumber the catch's): likely two regimes; weigh a split at the next sample
            self._split_check, self._next_fit = 0, self._y_count + 1

    def _land(self, built: Built, keep: np.ndarray | None, memory: tuple) -> None:
        """Served live: the memory thinned as the fitter chose (`keep`, if it did) and the factor it built over
        that, extended by what was taught since; rebuilt where the memory was thinned here since (its rows
        moved), a batch left the factor stale, or gp_factor.extend declines."""
        seen_m, thins, seen_repeats = memory
        if self._thins != thins or self._m < seen_m:
            self._rebuild()
            return
        if keep is not None:
            self._keep(np.concatenate([keep, np.arange(seen_m, self._m)]))
            seen_m, seen_repeats = len(keep), seen_repeats[keep]
        shape = Shape(self._inv_ell, self._smooth, self._linear, built.ratio)
        if self._factored and not self._stale and extend(
                built, seen_m, seen_repeats, self._xs, self._ys[:self._m] - self._hyper.mu, self._repeats, self._m,
                self._hyper.centre, shape, self._chol, self._beta, self._noise(self._m)):
            self._ratio = built.ratio
            self._factor_changed(0)
        else:
            self._rebuild()

    def _use(self, hyper: Hyper, seen: tuple | None = None, rebuild: bool = True) -> None:
        """Adopt a fit: the kernel's working quantities, the factor, and the refit triggers' baselines:
        the spread and count the fit saw (learning that went on while it ran is yet to be fitted)."""
        self._hyper = hyper
        self._inv_ell, self._smooth, self._linear, self._ratio = shape_of(hyper, self.noise_floor)
        self._fitted_sd, self._last_fit = seen if seen is not None else (self._input_sd(), self._y_count)
        self._surprise = 0.0
        if rebuild:
            self._rebuild()
