"""The page's messages and its server's doors, without a bus: what is accepted, what is refused and why."""
import asyncio
import json
import logging
import socket
import ssl
import threading

import pytest
from websockets.asyncio.client import connect
from websockets.exceptions import InvalidMessage, InvalidStatus

from rigs.harness import free_port
from services.certificates import make_certs
from services.ui.protocol import BadMessage, parse
from services.ui.server import UiServer
from services.ui.tls import TlsError, fingerprint, server_tls


def test_well_formed_messages_are_accepted():
    assert parse('{"op": "teach", "teacher": "seeker", "on": true}', 2).fields == {"teacher": "seeker", "on": True}
    assert parse('{"op": "teach", "teacher": "", "on": false, "hold": true}', 2).fields["hold"] is True
    assert parse('{"op": "teleop", "y": [1, null], "sent": 12.5}', 2).fields == {"y": [1.0, None], "sent": 12.5}
    assert parse('{"op": "arena", "seed": 3, "balls": {"pink": [0.9, 0.3], "orange": null}}', 2).fields["balls"] == {
        "pink": [0.9, 0.3], "orange": None}
    assert parse('{"op": "swap", "service": "learner", "spec": "knn"}', 2).op == "swap"


@pytest.mark.parametrize("raw, reason", [
    (b'{"op": "ping"}', "binary"),
    ("[1, 2]", "JSON object"),
    ('{"op": "teleop", "y": [0.5]}', "list of 2 entries"),
    ('{"op": "teleop", "y": [true, 0]}', "number in [-1, 1]"),
    ('{"op": "teleop", "y": [Infinity, 0]}', "not a number JSON allows"),
    ('{"op": "teach", "teacher": "seeker"}', "missing field 'on'"),
    ('{"op": "teach", "teacher": "seeker", "on": true, "extra": 1}', "unknown fields extra"),
    ('{"op": "teach", "teacher": "../x", "on": true}', "lowercase"),
    ('{"op": "arena", "seed": -1, "balls": {}}', "integer from 0"),
    ('{"op": "arena", "seed": 1, "balls": {"pink": [1000, 0]}}', "within 10 m"),
    ('{"op": "swap", "service": "learner", "spec": "k\\nn"}', "printable"),
    ("[" * 5000, "at most 4096"),
    ("[" * 4000, "not JSON"),
])
def test_malformed_messages_are_refused_with_a_reason(raw, reason):
    with pytest.raises(BadMessage, match=None) as err:
        parse(raw, 2)
    assert reason in str(err.value)


class Bridge:
    def __init__(self):
        self.requests = []

    def request(self, op, fields, reply):
        self.requests.append((op, fields))
        reply("done", True)


def serve(token=None, tls=None):
    """A UiServer on a free port in a thread; returns (server, port, stop)."""
    hello = {"outputs": {"names": ["forward", "turn"]}, "instance": "main"}
    server = UiServer(Bridge(), hello, "127.0.0.1", free_port(), token, logging.getLogger("test"), tls)
    stop, up = threading.Event(), threading.Event()
    threading.Thread(target=lambda: asyncio.run(server.serve(stop, lambda port: up.set())), daemon=True).start()
    assert up.wait(10)
    return server, server.port, stop


async def exchange(url, messages, origin=None, ssl=None):
    async with connect(url, origin=origin, ssl=ssl) as ws:
        hello = json.loads(await ws.recv())
        answers = []
        for m in messages:
            await ws.send(m)
            answers.append(json.loads(await ws.recv()))
        return hello, answers


def test_the_server_acts_on_good_requests_and_refuses_bad_ones_without_closing():
    server, port, stop = serve()
    try:
        hello, answers = asyncio.run(exchange(f"ws://127.0.0.1:{port}/ws", [
            '{"op": "teach", "teacher": "seeker", "on": true}', "{bad", '{"op": "teleop", "y": [0, 2]}',
            '{"op": "teach", "teacher": "seeker", "on": false}']))
        assert hello["type"] == "hello"
        assert [a["type"] for a in answers] == ["reply", "error", "error", "reply"]
        assert server.bridge.requests == [("teach", {"teacher": "seeker", "on": True}),
                                          ("teach", {"teacher": "seeker", "on": False})]
        assert server.rejected["message"] == 2
    finally:
        stop.set()


def test_another_sites_page_and_a_wrong_token_are_refused():
    server, port, stop = serve(token="s3cret")
    try:
        with pytest.raises(InvalidStatus, match="401"):
            asyncio.run(exchange(f"ws://127.0.0.1:{port}/ws?token=wrong", []))
        with pytest.raises(InvalidStatus, match="403"):
            asyncio.run(exchange(f"ws://127.0.0.1:{port}/ws?token=s3cret", [], origin="http://evil.example"))
        hello, _ = asyncio.run(exchange(f"ws://127.0.0.1:{port}/ws?token=s3cret", [],
                                        origin=f"http://127.0.0.1:{port}"))
        assert hello["instance"] == "main"
        assert server.rejected == {"token": 1, "origin": 1}
    finally:
        stop.set()


def bridge_on_fake_bus():
    from bus_schema import Box, Spaces
    from services.ui.bridge import Bridge as BusBridge
    from tests.fakebus import fake_box
    output = Box([-0.15, -0.8], [0.15, 0.8], ["forward", "turn"], ["m/s", "rad/s"])
    spaces = Spaces(Box.uniform(3, -1.0, 1.0, "x", "1"), output)
    views = []
    box = fake_box("ui", "ui")
    return BusBridge(box, "aibo", "person", spaces, lambda kind, p: views.append((kind, p))), box.session, views


def test_the_person_teaches_only_what_they_press_and_lets_go():
    import time

    import numpy as np

    from bus_schema import Input, Proposal, decode, encode
    bridge, bus, _ = bridge_on_fake_bus()
    bridge.on_input("dl/main/input", encode(Input(41, time.time(), np.zeros(3))), None)
    bridge.on_page("teleop", {"y": [1.0, None]}, None)  # only the up arrow
    assert [t.key for t in bus.tokens] == ["dl/main/alive/teaching/person"]
    said = decode(Proposal, bus.on("dl/main/proposal/teacher/person")[-1], "k")
    assert said.tick == 41 and np.allclose(said.y[0], 0.15) and list(said.mask) == [1.0, 0.0]
    bridge.on_input("dl/main/input", encode(Input(42, time.time(), np.zeros(3))), None)
    assert decode(Proposal, bus.on("dl/main/proposal/teacher/person")[-1], "k").tick == 42
    bridge.on_page("teleop", {"y": [None, None]}, None)  # let go
    assert bus.tokens == []
    bridge.on_page("teleop", {"y": [-1.0, 1.0]}, None)
    bridge.teleop.said_at -= 1.0  # not refreshed: the page is gone
    bridge.teleop.expire()
    assert bus.tokens == []


def test_names_the_page_would_show_are_checked():
    import zenoh

    from bus_schema import Status, encode
    bridge, _, _ = bridge_on_fake_bus()
    bridge.on_alive("dl/main/alive/learner/<img src=x onerror=alert(1)>", None, zenoh.SampleKind.PUT)
    bridge.on_alive("dl/main/alive/learner/knn", None, zenoh.SampleKind.PUT)
    bridge.on_status("dl/main/status/learner/knn", encode(Status("learner", "knn", 7, {}, {
        "rates": {"learned": 3.0, "<b>": 1.0, "nan": float("nan")}})), None)
    assert list(bridge.services) == ["main/learner/knn"]
    assert bridge.services["main/learner/knn"]["rates"] == {"learned": 3.0}
    assert bridge.rejects.total == 1


def tls_client() -> ssl.SSLContext:
    """A client that takes any certificate: the tests compare its fingerprint, as a person does in the browser."""
    context = ssl.SSLContext(ssl.PROTOCOL_TLS_CLIENT)
    context.check_hostname, context.verify_mode = False, ssl.CERT_NONE
    return context


def served_fingerprint(port: int) -> str:
    with socket.create_connection(("127.0.0.1", port), timeout=5) as raw:
        with tls_client().wrap_socket(raw) as wrapped:
            return fingerprint(ssl.DER_cert_to_PEM_cert(wrapped.getpeercert(binary_form=True)).encode())


def test_off_loopback_the_page_is_https_with_the_printed_certificate_and_plain_http_gets_nothing():
    context, printed = server_tls("0.0.0.0")  # no certificate given: one made for the run
    server, port, stop = serve(token="s3cret", tls=context)
    try:
        assert served_fingerprint(port) == printed and len(printed) == 95  # 32 bytes, AB:CD:...
        hello, _ = asyncio.run(exchange(f"wss://127.0.0.1:{port}/ws?token=s3cret", [], ssl=tls_client()))
        assert hello["instance"] == "main"
        with pytest.raises((ConnectionError, OSError, InvalidMessage)):  # no clear-text door
            asyncio.run(exchange(f"ws://127.0.0.1:{port}/ws?token=s3cret", []))
        with pytest.raises(InvalidStatus, match="401"):  # TLS is no login: the token still decides
            asyncio.run(exchange(f"wss://127.0.0.1:{port}/ws?token=wrong", [], ssl=tls_client()))
    finally:
        stop.set()


def test_a_given_certificate_serves_the_page_and_bad_ones_are_named(tmp_path):
    [cert] = make_certs(tmp_path / "certs", ["operator.alice"])  # `dogged certs` makes one a browser can trust
    key = cert.with_suffix(".key")
    context, printed = server_tls("127.0.0.1", cert, key)
    server, port, stop = serve(tls=context)
    try:
        assert served_fingerprint(port) == printed == fingerprint(cert.read_bytes())
    finally:
        stop.set()
    (tmp_path / "junk.pem").write_text("not a certificate")
    for args, named in [((cert, None), "--tls-key is needed too"), ((None, key), "--tls-cert is needed too"),
                        ((tmp_path / "none.pem", key), "--tls-cert"), ((tmp_path / "junk.pem", key), "--tls-cert"),
                        ((cert, tmp_path / "certs-ca" / "ca.key"), "do not make a certificate chain")]:
        with pytest.raises(TlsError, match=named):
            server_tls("127.0.0.1", *args)


def test_what_the_bus_thread_hands_over_after_the_server_stopped_is_dropped_not_raised():
    """The bus thread may emit while the event loop closes (a dogged ui stopping); it used to die with
    'Event loop is closed', leaving the person's teaching held."""
    hello = {"outputs": {"names": ["forward", "turn"]}, "instance": "main"}
    server = UiServer(Bridge(), hello, "127.0.0.1", free_port(), None, logging.getLogger("test"))
    stop, up = threading.Event(), threading.Event()
    thread = threading.Thread(target=lambda: asyncio.run(server.serve(stop, lambda port: up.set())))
    thread.start()
    assert up.wait(10) and server.loop is not None
    stop.set()
    thread.join(10)
    assert server.loop is None  # let go before its loop closed
    server.emit("view", {"type": "view"})
    closed = asyncio.new_event_loop()
    closed.close()
    server.loop = closed  # the window between the check and the hand-over
    server.emit("view", {"type": "view"})
