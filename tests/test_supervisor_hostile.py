"""A stranger on the bus cannot take the supervisor down (issue 12): bad parameters, unknown verbs,
a swap to no learner and forged statuses are answered, refused or bounded; the deployment keeps running."""
import json
import time

import pytest
import zenoh

from bus_schema import ControlReply, Status, decode, encode, supervisor_key
from rigs.harness import dogged, dogged_ok, free_port, wait_until
from services.bus.config import zenoh_config
from tests.test_supervisor import PROFILE, ps

pytestmark = pytest.mark.live


def ask(session, verb: str, parameters: str = "") -> ControlReply:
    key = supervisor_key("suptest", verb)
    replies = [r for r in session.get(f"{key}?{parameters}" if parameters else key, timeout=10.0) if r.ok is not None]
    assert replies, f"no answer to {verb}?{parameters}"
    return decode(ControlReply, replies[0].ok.payload.to_bytes(), key)


def test_hostile_queries_and_a_forged_status_leave_the_supervisor_running(tmp_path):
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    profile = tmp_path / "suptest.toml"
    # a stranger the bus lets in (security off; a secured bus refuses its puts at the door): what this tries
    # is the supervisor's own checks
    profile.write_text(PROFILE.format(logs=tmp_path / "logs", state=tmp_path / "state") + '[zenoh]\nsecurity = "off"\n')
    sup = dogged("up", str(profile), "--router", endpoint, "--quiet", log=tmp_path / "supervisor.log")
    try:
        wait_until(lambda: (r := ps(endpoint)) and all(x["state"] == "ready" for x in r.values()), 90, "ready")
        with zenoh.open(zenoh_config(connect=[endpoint], mode="client")) as session:
            answers = {f"{verb}?{params}": ask(session, verb, params) for verb, params in (
                ("logs", "service=learner;lines=abc"), ("logs", "service=learner;lines=-5"),
                ("logs", "service=learner;lines=99999999999999999999"), ("logs", "service=nobody"),
                ("ps", "evil=1"), ("shutdown", ""), ("DOWN", ""), ("down", "now=1"))}
            began = time.monotonic()
            answers["swap?spec=nosuch"] = ask(session, "swap", "spec=nosuch")
            swap_seconds = time.monotonic() - began
            forged = Status("learner", "learner", 1, {"pairs": 1}, {"rates": [1, 2, 3]})
            for name in ("learner", "arbitrator"):  # the second says it is the learner on another's key
                session.put(f"dl/main/status/{name}/{name}", encode(forged))
            # well-formed strangers under 300 names, a name no service may have, a key that is not its own
            for i in range(300):
                session.put(f"dl/main/status/teacher/ghost{i}", encode(Status("teacher", f"ghost{i}", 7, {}, {})))
            session.put("dl/main/status/teacher/Bad Name", encode(Status("teacher", "Bad Name", 7, {}, {})))
            session.put("dl/main/status/teacher/ghost0", encode(Status("teacher", "other", 7, {}, {})))
            time.sleep(1.5)
            listed = ask(session, "ps")
        assert {k: a.ok for k, a in answers.items()} == {k: False for k in answers}, \
            {k: a.text for k, a in answers.items()}
        assert "lines must be an integer" in answers["logs?service=learner;lines=abc"].text
        assert "no verb 'shutdown'" in answers["shutdown?"].text
        assert "no learner 'nosuch'" in answers["swap?spec=nosuch"].text and swap_seconds < 5.0
        assert listed.ok and listed.data["refused"]["logs"] == 4 and listed.data["refused"]["unknown"] == 2
        assert listed.data["refused"]["status"] == 3, listed.data["refused"]
        remote = [r["name"] for r in listed.data["services"] if r["state"] == "remote"]
        assert len(remote) == 64 and all(n.startswith("ghost") for n in remote), remote  # the freshest 64 only
        own = [r for r in ps(endpoint).values() if r["state"] != "remote"]  # the ghosts are listed, as remote
        assert sup.poll() is None and len(own) == 6 and all(r["state"] == "ready" for r in own), own
        assert dogged_ok("logs", "learner", "-n", "5", endpoint=endpoint).returncode == 0
        assert json.loads(dogged_ok("ps", "--json", endpoint=endpoint).stdout)["services"]
    finally:
        down = dogged_ok("down", endpoint=endpoint)
        code = sup.wait(60)
    assert down.returncode == 0 and code == 0
