"""How a learner box starts from what another had: an earlier run's log (a restart), or the old learner's snapshot
and history (a hot-swap), put in its backlog to be learned between answers (services.boxes.learner)."""
from __future__ import annotations

import time

import numpy as np

from bus_schema import PairBatch, Snapshot, TrainingPair
from services.learners.base import SnapshotError

# a hot-swap's new learner asks the old one again while it does not answer (killed mid-swap and restarted:
# a cold start would lose every pair the arbitrator no longer holds); the swap waits for it (ready_timeout_s)
WARM_WAIT_S, ASK_AGAIN_S = 30.0, 0.5


class Warming:
    """LearnerNode's warming: it holds the model, pair log, backlog, epoch and seq, and asks with query()."""

    def replay(self, pairs: list[TrainingPair]):
        """An earlier run's log (already in the pair log): learned between answers, from the first."""
        self.backlog.extend((p.x, p.y, p.mask, p.source) for p in pairs)
        if pairs:
            self.epoch, self.seq = pairs[-1].epoch, pairs[-1].seq
        self.counts["replayed"] = len(pairs)

    def ask_until(self, deadline: float, key, cls, parameters="", timeout=5.0):
        """query(), asked again until it is answered or `deadline` (monotonic) has passed."""
        while True:
            answer = self.query(key, cls, parameters, timeout)
            if answer is not None or time.monotonic() >= deadline:
                return answer
            time.sleep(ASK_AGAIN_S)

    def warm_from(self, old: str) -> bool:
        """Take over from learner `old`: its snapshot if the class matches, else learn its history. While
        `old` does not answer (killed, its supervisor restarting it) it is asked again, for WARM_WAIT_S."""
        deadline = time.monotonic() + WARM_WAIT_S
        snap = self.ask_until(deadline, self.keys.snapshot(old), Snapshot, timeout=10.0)
        if snap is None:
            return self.start_cold(f"learner {old} did not answer with a snapshot")
        # all it holds: the snapshot covers the first n_learned rows (up to seq), the rest it had yet to learn
        history = self.ask_until(deadline, self.keys.history(old), PairBatch, f"epoch={snap.epoch}", timeout=30.0)
        if history is None or history.epoch != snap.epoch:
            return self.start_cold(f"learner {old}'s history did not come")
        last = history.first_seq + len(history.x) - 1
        covered = len(history.x) - (last - snap.seq)  # the rows its snapshot has learned
        if covered != snap.n_learned:
            return self.start_cold(f"learner {old}'s history ({len(history.x)} pairs to seq {last}) does not hold "
                                   f"its snapshot's {snap.n_learned} (to seq {snap.seq})")
        restored = None
        if snap.learner_class == type(self.model).__name__:
            try:
                restored = type(self.model).restore(snap.blob)
            except SnapshotError as err:  # never run: learn the history instead
                self.rejects(self.keys.snapshot(old), err)
        if restored is not None and not same_params(restored, self.model):
            # the same class asked with other hyper-parameters: what was asked for learns the history
            self.log.info("learner %s's snapshot has %s; asked for %s: learning its history instead", old,
                          restored.get_params(), self.model.get_params())
            restored = None
        if restored is not None:
            self.model = restored  # served live once it has learned the rest (serve_live_once_caught_up)
            how, start = "snapshot", covered
            self.counts["warmed_by_snapshot"] = 1
        else:
            how, start = f"training on {len(history.x)} pairs", 0
        sources = history.sources() or ["history"] * len(history.x)  # (an old learner may not say who taught)
        for i, (x, y, mask, source) in enumerate(zip(history.x, history.y, history.mask, sources)):
            mask = None if np.all(mask == 1) else mask
            self.pairs.append(TrainingPair(snap.epoch, history.first_seq + i, -1, x, y, source, mask))
            if i >= start:  # learned between answers (catch_up), before the swap selects this learner
                self.backlog.append((x, y, mask, source))
        self.epoch, self.seq = snap.epoch, last
        self.counts["warmed"] = len(history.x)
        self.log.info("warmed from %s by %s (%d pairs to learn; to seq %d of epoch %s)", old, how, len(self.backlog),
                      last, snap.epoch)
        return True

    def start_cold(self, why: str) -> bool:
        self.log.error("%s; starting cold", why)
        self.counts.update(warmed=0, warm_failed=1)  # the swap's answer says so
        return False


def same_params(a, b) -> bool:
    """Whether two learners were made with the same hyper-parameters (as their reprs say them)."""
    return {k: repr(v) for k, v in a.get_params().items()} == {k: repr(v) for k, v in b.get_params().items()}
