"""Who may say what (issue 12): a real router process with mutual TLS and the access control of
services/security.py; real sessions with real certificates try what a stranger and a teacher would."""
import json
import time

import pytest
import zenoh

from services.security import access_control, identity, make_certs
from tests.harness import dogged, free_port, stop, wait_until

IDENTITIES = ["router.router", "platform.aibo", "arbitrator.arbitrator", "learner.learner", "teacher.alice",
              "operator.bob", "supervisor.main", "perception.perception"]


def session_config(endpoint: str, directory, cn: str) -> zenoh.Config:
    conf = zenoh.Config()
    conf.insert_json5("mode", '"client"')
    conf.insert_json5("scouting/multicast/enabled", "false")
    conf.insert_json5("connect/endpoints", json.dumps([endpoint]))
    from services.security import tls_section
    conf.insert_json5("transport/link/tls", json.dumps(tls_section(directory, cn)))
    return conf


@pytest.fixture(scope="module")
def secured(tmp_path_factory):
    directory = tmp_path_factory.mktemp("certs")
    make_certs(directory, IDENTITIES)
    stranger = tmp_path_factory.mktemp("stranger")  # a valid-looking identity from another CA
    make_certs(stranger, ["teacher.alice"])
    endpoint = f"tls/127.0.0.1:{free_port()}"
    router = dogged("run", "router", "--listen", endpoint, log=directory / "router.log",
                    env={"DOGGED_SECURITY": str(directory), "DOGGED_IDENTITY": "router.router"})
    time.sleep(1.5)
    yield endpoint, directory, stranger
    stop(router)


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


def test_a_teacher_cannot_publish_what_only_others_may(secured):
    endpoint, directory, _ = secured
    assert heard(endpoint, directory, "teacher.alice", puts(*FORBIDDEN_TO_A_TEACHER,
                                                            "dl/main/proposal/teacher/alice")) \
        == ["dl/main/proposal/teacher/alice"]


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


def answers(endpoint, directory, key: str, owner: str, impostor: str) -> list[bytes]:
    """The replies to a query on `key` when both the owner and an impostor declare a queryable."""
    with zenoh.open(session_config(endpoint, directory, owner)) as a, \
            zenoh.open(session_config(endpoint, directory, impostor)) as b:
        qa = a.declare_queryable(key, lambda q: q.reply(key, b"owner"))
        qb = b.declare_queryable(key, lambda q: q.reply(key, b"impostor"))
        time.sleep(0.5)
        with zenoh.open(session_config(endpoint, directory, "operator.bob")) as asker:
            replies = [r.ok.payload.to_bytes() for r in asker.get(key, target=zenoh.QueryTarget.ALL,
                                                                consolidation=zenoh.ConsolidationMode.NONE, timeout=2.0)
                       if r.ok is not None]
        del qa, qb
    return sorted(replies)


@pytest.mark.parametrize("key,owner", [("dl/main/spaces", "platform.aibo"),
                                       ("dl/main/learner/learner/snapshot", "learner.learner"),
                                       ("dl/main/learner/learner/history", "learner.learner"),
                                       ("dogged/supervisor/main/down", "supervisor.main")])
def test_only_the_owner_answers_the_queries_a_deployment_depends_on(secured, key, owner):
    endpoint, directory, _ = secured
    assert answers(endpoint, directory, key, owner, "teacher.alice") == [b"owner"]


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
    rules = access_control(["teacher.alice", "arbitrator.arbitrator"])
    denied_to_teachers = {k for r, p in zip(rules["rules"], rules["policies"]) if "s-teacher" in p["subjects"]
                          for k in r["key_exprs"]}
    assert "dl/*/command" in denied_to_teachers and "dl/*/proposal/teacher/**" not in denied_to_teachers


def test_peers_linked_directly_enforce_the_rules_themselves(secured, monkeypatch):
    """Services join as peers that link straight to each other over TLS (a hop fewer than through the
    router); a teacher's peer linked straight to the robot's still cannot command it."""
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
        for _ in range(5):
            arbitrator.put("dl/main/command", b"arbitrator")
            alice.put("dl/main/command", b"alice")
            time.sleep(0.05)
        time.sleep(0.5)
        del held
    assert set(got) == {b"arbitrator"}
