"""The box runtime (services/bus/runtime.py) on the fake bus: what a box declares reaches its loop as
events, in order and in batches; its status carries its counters, rejects and the inbox's drops; it is
announced alive when its loop starts and leaves nothing declared; it refuses declarations off its thread."""
import threading

import numpy as np
import pytest
import zenoh

from bus_schema import Input, Status, decode, encode
from services.bus.inbox import decode_or_reject
from services.bus.runtime import BoxRuntime
from tests.fakebus import FakeSession, FakeStop, fake_box


def test_what_a_box_declares_comes_to_its_loop_in_order_and_its_status_says_what_it_did():
    box = fake_box("teacher", "echo", turns=2)
    bus = box.session
    box.subscribe(box.keys.input, "input")
    box.subscribe_alive(box.keys.alive_all, "alive")
    box.queryable(box.keys.spaces, "spaces")
    assert bus.tokens == [], "not alive before its loop starts"
    bus.deliver(box.keys.input, encode(Input(1, 0.0, np.zeros(2))))
    bus.deliver_alive(box.keys.alive("learner", "l"))
    query = bus.query(box.keys.spaces, "a=1")
    bus.deliver(box.keys.input, b"\xc1 not msgpack")
    seen = []
    for batch in box.batches(0.0, lambda: ({"mine": 7}, {"state": "here"})):
        assert [t.key for t in bus.tokens] == [box.keys.alive("teacher", "echo")]
        for tag, key, raw, kind in batch:
            seen.append((tag, key))
            if tag == "input":
                box.counts["inputs"] += decode_or_reject(Input, raw, key, box.rejects) is not None
            elif tag == "spaces":
                raw.reply(key, b"answer")
            else:
                assert kind == zenoh.SampleKind.PUT
    assert seen == [("input", box.keys.input), ("alive", box.keys.alive("learner", "l")),
                    ("spaces", box.keys.spaces), ("input", box.keys.input)]
    assert query.replies == [(box.keys.spaces, b"answer")]
    [status] = [decode(Status, raw, "k") for raw in bus.on(box.keys.status("teacher", "echo"))]
    assert (status.role, status.name, status.state["state"]) == ("teacher", "echo", "here")
    assert status.counters == {"inputs": 1, "mine": 7, "rejected": 1, "inbox_dropped": 0}
    box.__exit__(None, None, None)
    assert bus.tokens == bus.subscribers == bus.alive_subscribers == bus.queryables == []


def test_the_wait_is_asked_before_every_batch_and_the_loop_ends_when_stopped():
    box, waits = fake_box(turns=3), []
    batches = [list(batch) for batch in box.batches(lambda: waits.append(len(waits)) or 0.0)]
    assert waits == [0, 1, 2] and batches == [[], [], []]
    box.stop.set()
    assert list(fake_box(turns=0).batches(0.0)) == []


def test_a_status_asked_for_soon_goes_out_at_the_next_batch_not_a_second_later():
    box = fake_box(turns=3)
    key = box.keys.status("test", "test")
    for turn, _ in enumerate(box.batches(0.0)):
        if turn == 1:
            box.status.publish_soon()
    assert len(box.session.on(key)) == 2, "the first status, then the one asked for: not one a turn"


def test_a_released_declaration_hears_nothing_more():
    box = fake_box()
    listening = box.subscribe(box.keys.input, "input")
    teaching = box.token(box.keys.teaching("t"))
    box.release(listening)
    box.release(teaching)
    assert box.session.deliver(box.keys.input, b"x") == 0 and box.session.tokens == []
    assert box.inbox.waiting == 0


@pytest.mark.parametrize("daemon", [True, False])
def test_declarations_off_the_runtimes_thread_are_refused(daemon):
    box, refused = fake_box(), []

    def declare():
        for declare_one in (lambda: box.subscribe("dl/main/input", "input"),
                            lambda: box.queryable("dl/main/spaces", "spaces"),
                            lambda: box.subscribe_alive("dl/main/alive/**", "alive")):
            try:
                declare_one()
            except RuntimeError as err:
                refused.append(str(err))
    thread = threading.Thread(target=declare, name="worker", daemon=daemon)
    thread.start()
    thread.join(10)
    assert len(refused) == 3 and "declares its subscriptions and queryables on the thread that made" in refused[0]
    assert "not on worker" in refused[0]
    assert box.session.subscribers == box.session.queryables == box.session.alive_subscribers == []


def test_a_box_without_instance_keys_says_it_is_up_on_its_own_token_and_has_no_status():
    bus = FakeSession()
    box = BoxRuntime(bus, None, "router", "router", token="@/router/up", stop=FakeStop(1)).open()
    assert box.status is None and [list(batch) for batch in box.batches(0.0)] == [[]]
    assert [t.key for t in bus.tokens] == ["@/router/up"] and bus.published == []
