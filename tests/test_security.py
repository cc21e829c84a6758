"""Who may say what (issues 12 and 30): a real router process with mutual TLS and the access control of
services/security.py; real sessions with real certificates try what a stranger, a teacher, a certificate
made after the router started and a router's certificate not the router's own would."""
import contextlib
import json
import logging
import time

import pytest
import zenoh

from rigs.harness import dogged, free_port, stop, wait_until
from services.certificates import make_certs
from services.refusals import Refusals
from services.security import access_control, identity

# router.mallet: a router's certificate, made before the router started, that is not the router's own
IDENTITIES = ["router.router", "platform.aibo", "arbitrator.arbitrator", "learner.learner", "teacher.alice",
              "operator.bob", "supervisor.main", "perception.perception", "router.mallet"]


def session_config(endpoint: str, directory, cn: str) -> zenoh.Config:
    conf = zenoh.Config()
    conf.insert_json5("mode", '"client"')
    conf.insert_json5("scouting/multicast/enabled", "false")
    conf.insert_json5("connect/endpoints", json.dumps([endpoint]))
    from services.security import tls_section
    conf.insert_json5("transport/link/tls", json.dumps(tls_section(directory, cn)))
    return conf


@contextlib.contextmanager
def secured_router(tmp_path_factory, identities=IDENTITIES):
    """A router enforcing the roster `identities` (each given a certificate): (its endpoint, the certs
    directory, a directory of another CA's teacher.alice)."""
    directory = tmp_path_factory.mktemp("certs")
    make_certs(directory, identities)
    stranger = tmp_path_factory.mktemp("stranger")  # a valid-looking identity from another CA
    make_certs(stranger, ["teacher.alice"])
    endpoint = f"tls/127.0.0.1:{free_port()}"
    router = dogged("run", "router", "--listen", endpoint, log=directory / "router.log",
                    env={"DOGGED_SECURITY": str(directory), "DOGGED_IDENTITY": "router.router"})
    time.sleep(1.5)
    try:
        yield endpoint, directory, stranger
    finally:
        stop(router)


@pytest.fixture(scope="module")
def secured(tmp_path_factory):
    with secured_router(tmp_path_factory) as router:
        yield router


def heard(endpoint, directory, speaker: str, actions) -> list[str]:
    """What a listener (operator.bob) hears of dl/** and robot/** while `speaker` acts."""
    got = []
    with zenoh.open(session_config(endpoint, directory, "operator.bob")) as listener:
        subs = [listener.declare_subscriber(k, lambda s: got.append(str(s.key_expr))) for k in ("dl/**", "robot/**")]
        with zenoh.open(session_config(endpoint, directory, speaker)) as session:
            time.sleep(0.5)
            actions(session)
            time.sleep(0.5)
        del subs
    return sorted(set(got))


def puts(*keys):
    return lambda session: [session.put(k, b"x") for k in keys]


FORBIDDEN_TO_A_TEACHER = ("dl/main/command", "dl/main/input", "dl/main/train", "dl/main/arbitrator/select",
                          "dl/main/teach", "dl/main/proposal/learner/learner", "robot/aibo/state")


@pytest.mark.live
def test_a_teacher_cannot_publish_what_only_others_may(secured):
    endpoint, directory, _ = secured
    assert heard(endpoint, directory, "teacher.alice", puts(*FORBIDDEN_TO_A_TEACHER,
                                                            "dl/main/proposal/teacher/alice")) \
        == ["dl/main/proposal/teacher/alice"]


@pytest.mark.live
def test_the_owners_can(secured):
    endpoint, directory, _ = secured
    assert heard(endpoint, directory, "arbitrator.arbitrator", puts("dl/main/command", "dl/main/train",
                                                                    "dl/main/applied")) \
        == ["dl/main/command", "dl/main/train"]
    # the platform reports what it applied (the rules once gave that key to the arbitrator)
    assert heard(endpoint, directory, "platform.aibo", puts("dl/main/input", "dl/main/applied", "robot/aibo/camera")) \
        == ["dl/main/applied", "dl/main/input", "robot/aibo/camera"]
    # ball seeking's input is what perception makes of the camera (the rules once left it out)
    assert heard(endpoint, directory, "perception.perception", puts("dl/main/input", "robot/aibo/camera")) \
        == ["dl/main/input"]
    assert heard(endpoint, directory, "operator.bob", puts("dl/main/teach")) == ["dl/main/teach"]


def answers(endpoint, directory, key: str, owner: str, impostor: str, asker: str = "operator.bob") -> list[bytes]:
    """The replies `asker` gets to a query on `key` when both the owner and an impostor declare a queryable."""
    with zenoh.open(session_config(endpoint, directory, owner)) as a, \
            zenoh.open(session_config(endpoint, directory, impostor)) as b:
        qa = a.declare_queryable(key, lambda q: q.reply(key, b"owner"))
        qb = b.declare_queryable(key, lambda q: q.reply(key, b"impostor"))
        time.sleep(0.5)
        with zenoh.open(session_config(endpoint, directory, asker)) as asking:
            replies = [r.ok.payload.to_bytes() for r in asking.get(key, target=zenoh.QueryTarget.ALL,
                                                                consolidation=zenoh.ConsolidationMode.NONE, timeout=2.0)
                       if r.ok is not None]
        del qa, qb
    return sorted(replies)


@pytest.mark.live
@pytest.mark.parametrize("key,owner,asker", [("dl/main/spaces", "platform.aibo", "operator.bob"),
                                             ("dl/main/learner/learner/snapshot", "learner.learner", "learner.learner"),
                                             ("dl/main/learner/learner/history", "learner.learner", "learner.learner"),
                                             ("dogged/supervisor/main/down", "supervisor.main", "operator.bob")])
def test_only_the_owner_answers_the_queries_a_deployment_depends_on(secured, key, owner, asker):
    """(Only a learner, warming for a hot-swap, asks another learner's snapshot and history.)"""
    endpoint, directory, _ = secured
    assert answers(endpoint, directory, key, owner, "teacher.alice", asker) == [b"owner"]


@pytest.mark.live
def test_a_teacher_cannot_call_the_supervisor(secured):
    endpoint, directory, _ = secured
    with zenoh.open(session_config(endpoint, directory, "supervisor.main")) as supervisor:
        called = []
        held = supervisor.declare_queryable("dogged/supervisor/main/*", lambda q: (called.append(str(q.key_expr)),
                                                                                    q.reply(q.key_expr, b"ok")))
        for who, verb in (("teacher.alice", "down"), ("teacher.alice", "swap"), ("operator.bob", "ps")):
            with zenoh.open(session_config(endpoint, directory, who)) as caller:
                time.sleep(0.3)
                list(caller.get(f"dogged/supervisor/main/{verb}", timeout=1.0))
        del held
    assert called == ["dogged/supervisor/main/ps"]


@pytest.mark.live
def test_a_process_without_a_certificate_of_this_ca_cannot_join(secured):
    endpoint, _, stranger = secured
    with pytest.raises(zenoh.ZError):
        zenoh.open(session_config(endpoint, stranger, "teacher.alice"))
    plain = zenoh.Config()
    plain.insert_json5("mode", '"client"')
    plain.insert_json5("scouting/multicast/enabled", "false")
    plain.insert_json5("connect/endpoints", json.dumps([endpoint]))
    with pytest.raises(zenoh.ZError):
        zenoh.open(plain)


def test_identities_and_rules_are_checked():
    assert identity("teacher", "alice") == "teacher.alice"
    with pytest.raises(ValueError, match="role must be one of"):
        identity("wizard", "merlin")
    with pytest.raises(ValueError, match="not <role>.<name>"):
        access_control(["alice"])
    rules = access_control(["teacher.alice", "arbitrator.arbitrator", "router.router", "router.mallet"])
    by_id = {r["id"]: r for r in rules["rules"]}
    teachers = [by_id[i] for p in rules["policies"] if p["subjects"] == ["s-teacher"] for i in p["rules"]]
    puts = {k for r in teachers if r["messages"] == ["put"] for k in r["key_exprs"]}
    assert "dl/*/proposal/teacher/*" in puts and "dl/*/command" not in puts
    # an allow-list: nothing is denied by a rule, and only listening and delivery are allowed on every key
    assert {r["permission"] for r in rules["rules"]} == {"allow"}
    assert {r["id"] for r in rules["rules"] if "**" in r["key_exprs"]} == {"listen", "deliver"}
    assert by_id["deliver"]["flows"] == ["egress"]
    # denied by default: only the roster's identities are named, and of the router role only the router's own
    assert rules["default_permission"] == "deny"
    assert {cn for s in rules["subjects"] for cn in s["cert_common_names"]} == {
        "teacher.alice", "arbitrator.arbitrator", "router.router"}


def robot_hears(secured, monkeypatch, speak) -> list[bytes]:
    """What the robot's peer (platform.aibo) hears on dl/main/command while speak(arbitrator, alice) runs,
    each of the three a peer linked straight to the others over TLS."""
    from services.bus.config import zenoh_config
    endpoint, directory, _ = secured

    def peer(cn):
        monkeypatch.setenv("DOGGED_SECURITY", str(directory))
        monkeypatch.setenv("DOGGED_IDENTITY", cn)
        return zenoh.open(zenoh_config(connect=[endpoint], mode="peer"))

    got = []
    with peer("platform.aibo") as robot, peer("arbitrator.arbitrator") as arbitrator, peer("teacher.alice") as alice:
        held = robot.declare_subscriber("dl/main/command", lambda s: got.append(s.payload.to_bytes()))
        others = {str(arbitrator.info.zid()), str(alice.info.zid())}
        wait_until(lambda: others <= {str(z) for z in robot.info.peers_zid()}, 10, "the peers to link directly", 0.1)
        time.sleep(0.5)
        speak(arbitrator, alice)
        time.sleep(0.5)
        del held
    return got


@pytest.mark.live
def test_peers_linked_directly_enforce_the_rules_themselves(secured, monkeypatch):
    """Services join as peers that link straight to each other over TLS (a hop fewer than through the
    router); a teacher's peer linked straight to the robot's still cannot command it."""
    def speak(arbitrator, alice):
        for _ in range(5):
            arbitrator.put("dl/main/command", b"arbitrator")
            alice.put("dl/main/command", b"alice")
            time.sleep(0.05)
    assert set(robot_hears(secured, monkeypatch, speak)) == {b"arbitrator"}


def overheard(endpoint, directory, listener: str) -> list[str]:
    """What `listener` hears of dl/** while the arbitrator commands and the platform reports."""
    got = []
    with zenoh.open(session_config(endpoint, directory, listener)) as session:
        held = session.declare_subscriber("dl/**", lambda s: got.append(str(s.key_expr)))
        time.sleep(0.5)
        heard(endpoint, directory, "arbitrator.arbitrator", puts("dl/main/command"))
        heard(endpoint, directory, "platform.aibo", puts("dl/main/input"))
        del held
    return sorted(set(got))


@pytest.mark.live
def test_a_certificate_made_after_the_router_started_gets_nothing(secured):
    """Signed by the same CA, but after the router read its roster: it matches no subject, so nothing it
    says passes and nothing reaches it; the router's log tells the refusal, with its name."""
    endpoint, directory, _ = secured
    make_certs(directory, ["teacher.eve", "operator.mallory"])
    assert heard(endpoint, directory, "teacher.eve", puts("dl/main/command", "dl/main/train",
                                                          "dl/main/proposal/teacher/eve")) == []
    assert heard(endpoint, directory, "operator.mallory", puts("dl/main/teach", "dl/main/arbitrator/select")) == []
    assert overheard(endpoint, directory, "teacher.eve") == []
    assert answers(endpoint, directory, "dogged/supervisor/main/down", "supervisor.main", "operator.mallory") \
        == [b"owner"]
    assert overheard(endpoint, directory, "teacher.alice") == ["dl/main/command", "dl/main/input"]  # on the roster
    refusals = Refusals(IDENTITIES, "router", logging.getLogger("test"))
    for line in (directory / "router.log").read_text().splitlines():
        refusals.note(line)
    assert {"teacher.eve", "operator.mallory"} <= set(refusals.counts())


@pytest.mark.live
def test_a_router_certificate_not_the_routers_own_gets_nothing(secured):
    """The rules never denied the router role: any `router.*` certificate could say anything."""
    endpoint, directory, _ = secured
    assert heard(endpoint, directory, "router.mallet", puts("dl/main/command", "dl/main/train", "dl/main/teach",
                                                            "robot/aibo/state")) == []
    assert overheard(endpoint, directory, "router.mallet") == []
    assert answers(endpoint, directory, "dl/main/spaces", "platform.aibo", "router.mallet") == [b"owner"]
