"""A swap waits for its new learner to catch up as long as it learns (services.supervisor.swap._catch_up), even when
teaching that goes on meanwhile makes its backlog grow; it gives up on a learner that learns nothing."""
from services.supervisor.swap import CATCH_UP_STALL_S, _catch_up

STATUS_EVERY_S = 10.0  # the fake's clock: one status a pump step


class Supervisor:
    """pump() reads the learner's statuses one at a time, STATUS_EVERY_S apart, until the predicate holds."""

    def __init__(self, statuses: list[dict]):
        self.statuses, self.now, self.stopping = list(statuses), {}, False

    def status_of(self, spec) -> dict:
        return self.now

    def pump(self, session, predicate, timeout: float) -> bool:
        for _ in range(int(timeout // STATUS_EVERY_S)):
            if not self.statuses:
                break
            self.now = self.statuses.pop(0)
            if predicate():
                return True
        return False


def said(seq, backlog) -> dict:
    return {"counters": {"seq": seq, "backlog": backlog}}


def test_taught_faster_than_it_learns_the_swap_waits_while_it_learns():
    # the history is 1000 pairs; a lesson adds 30 for every 20 learned, for longer than the stall allows, then ends
    statuses = [said(1000 + 30 * i, 1000 + 10 * i) for i in range(int(2 * CATCH_UP_STALL_S / STATUS_EVERY_S) + 2)]
    statuses += [said(statuses[-1]["counters"]["seq"], 400), said(statuses[-1]["counters"]["seq"], 0)]
    assert _catch_up(Supervisor(statuses), None, None) == ""


def test_a_learner_that_learns_nothing_is_given_up():
    statuses = [said(1000, 900)] + [said(1000 + 30 * i, 900 + 30 * i) for i in range(1, 8)]  # taught, learns none
    why = _catch_up(Supervisor(statuses), None, None)
    assert why.startswith(f"it learned no pair in {CATCH_UP_STALL_S:g} s"), why


def test_a_status_without_a_well_formed_backlog_is_no_progress():
    for counters in ({"seq": 10}, {"seq": 10, "backlog": "5"}, {"seq": True, "backlog": 0}, {"seq": 3, "backlog": -1}):
        why = _catch_up(Supervisor([{"counters": counters}] * 5), None, None)
        assert why == f"it did not say its backlog within {CATCH_UP_STALL_S:g} s", (counters, why)
