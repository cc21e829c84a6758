"""The demonstrator box on a fake bus: switched by the teach key, it holds its teaching token and
hears the inputs only while on, answers the newest input of a batch, and rejects what is malformed."""
import numpy as np

from bus_schema import InstanceKeys, Input, Proposal, Status, TeachSwitch, decode, encode
from bus_schema.spaces import Box, Spaces
from services.boxes.demonstrator import Demonstrator
from tests.fakebus import FakeStop, fake_box

KEYS = InstanceKeys("main")
SPACES = Spaces(Box((-1.0, -1.0), (1.0, 1.0)), Box((-1.0,), (1.0,)))


def doubler(x):
    return np.array([2 * x[0]]), 0.9


def bench(role="teacher"):
    runtime = fake_box(role, "doubler")
    box = Demonstrator(runtime, SPACES, doubler)
    box.listen(role == "default")
    return runtime.session, box


def step(bus, box, *puts):
    """Deliver each (key, payload) as the bus would, then let the box's loop handle what it heard (one turn)."""
    for key, payload in puts:
        bus.deliver(key, payload)
    box.box.stop = FakeStop(1)
    for batch in box.box.batches(0.0, box.report):
        box.handle(batch)


def teach(on, teacher=""):
    return KEYS.teach, encode(TeachSwitch(teacher, on))


def inp(tick, x=(0.25, 0.0)):
    return KEYS.input, encode(Input(tick, 0.0, np.array(x)))


def proposals(bus):
    return [decode(Proposal, p, KEYS.proposal("teacher", "doubler")) for p in bus.on(KEYS.proposal("teacher",
                                                                                                   "doubler"))]


def test_silent_until_switched_on_then_it_answers_the_newest_input_only():
    bus, box = bench()
    assert bus.deliver(*inp(1)) == 0 and not bus.tokens  # off: not even listening
    step(bus, box, teach(True))
    assert [t.key for t in bus.tokens] == [KEYS.alive("teacher", "doubler"), KEYS.teaching("doubler")]
    [status] = [decode(Status, raw, "k") for raw in bus.on(KEYS.status("teacher", "doubler"))]
    assert status.state["teaching"] is True and status.counters["switches"] == 1
    step(bus, box, inp(2, (0.1, 0.0)), inp(3, (0.3, 0.0)))
    [answer] = proposals(bus)
    assert answer.tick == 3 and np.allclose(answer.y, [0.6]) and answer.source == "teacher/doubler"
    step(bus, box, teach(True, "someone-else"), teach(False))
    assert [t.key for t in bus.tokens] == [KEYS.alive("teacher", "doubler")] and bus.deliver(*inp(4)) == 0
    assert box.counts["switches"] == 2 and box.counts["inputs"] == 2  # on and off; not the one for another teacher


def test_a_default_controller_always_answers_and_ignores_switches():
    bus, box = bench("default")
    step(bus, box, teach(False), inp(7))
    answers = [decode(Proposal, p, "k") for p in bus.on(KEYS.proposal("default", "doubler"))]
    assert [a.tick for a in answers] == [7] and box.counts["switches"] == 0
    assert [t.key for t in bus.tokens] == [KEYS.alive("default", "doubler")], "no teaching token: always on"


def test_malformed_and_hostile_inputs_are_rejected_and_counted_and_it_keeps_answering():
    bus, box = bench()
    step(bus, box, teach(True))
    step(bus, box, (KEYS.input, b"\xc1garbage"), (KEYS.input, encode(Input(5, 0.0, np.array([np.nan, 0.0])))),
         (KEYS.input, encode(Input(5, 0.0, np.zeros(3)))), (KEYS.teach, b"\x00"))
    assert box.rejects.total == 4 and not proposals(bus)
    step(bus, box, inp(6))
    assert [p.tick for p in proposals(bus)] == [6]
