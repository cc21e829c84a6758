from pathlib import Path

import pytest

from rigs.harness import REPO
from services.own_identities import identities_dir
from services.supervisor.profile import ProfileError, load_profile


def write(tmp_path, text):
    p = tmp_path / "p.toml"
    p.write_text(text)
    return p


def test_shipped_profiles_are_valid():
    for path in (REPO / "deploy").glob("*.toml"):
        profile = load_profile(path)
        assert profile.services, path


@pytest.mark.parametrize("text, message", [
    ("[services.a]\nbox = 'nonsense'", "services.a.box: expected one of"),
    ("[services.a]\nbox = 'learner'\nrestart = 'sometimes'", "services.a.restart: expected one of never"),
    ("[services.a]\nbox = 'learner'\nmax_restarts = 'x'", "services.a.max_restarts: expected int"),
    ("[services.a]\nbox = 'learner'\nargs = [1]", "services.a.args: expected a list of strings"),
    ("[services.a]\nbox = 'learner'\ncolour = 'red'", "services.a.colour: unknown field"),
    ("[services.A]\nbox = 'learner'", "services.A: service name 'A' must be lowercase"),
    ("[profile]\nname = 'x'", "services: at least one"),
    ("[servics.a]\nbox = 'learner'", "servics: unknown table"),
    ("[services.a\n", "not valid TOML"),
    ("[services.a]\nbox = 'learner'\nafter = ['b']", "services.a.after: 'b' is not another service"),
    ("[services.a]\nbox='learner'\nafter=['b']\n[services.b]\nbox='learner'\nafter=['a']", "cycle"),
    ("[profile]\nrecord = 'yes'\n[services.a]\nbox = 'learner'", "profile.record: expected bool"),
    ("[profile]\nrecord_rotate_mb = 0\n[services.a]\nbox = 'learner'", "record_rotate_mb and record_rotate_min must"),
    ("[services.recorder]\nbox = 'learner'", "services.recorder: the name of the profile's recorder"),
])
def test_errors_name_the_field(tmp_path, text, message):
    with pytest.raises(ProfileError, match=message.replace("(", r"\(").replace("[", r"\[")):
        load_profile(write(tmp_path, text))


def test_demonstrator_role_from_args(tmp_path):
    p = load_profile(write(tmp_path, "[services.d]\nbox='demonstrator'\nargs=['--role','default','--teacher','hold']"))
    assert {s.name: s for s in p.services}["d"].role == "default"


LEARNERS = ("[services.l]\nbox='learner'\n[services.k]\nbox='learner'\nargs=['--state-dir','own']\n"
            "[services.t]\nbox='demonstrator'\nargs=['--teacher','sine']\n")


@pytest.mark.parametrize("head, state", [
    ("[profile]\nlog_dir='run/logs'\n", "run/state"),          # by default beside the logs
    ("[profile]\nstate_dir='elsewhere'\n", "elsewhere"),
    ("[profile]\nstate_dir=''\n", None),                        # said so: learners forget on restart
])
def test_every_learner_keeps_its_state_unless_the_profile_says_not(tmp_path, head, state):
    p = load_profile(write(tmp_path, head + LEARNERS))
    args = {s.name: p.service_args(s) for s in p.services}
    assert args["l"] == (() if state is None else ("--state-dir", str(tmp_path / state)))
    assert args["k"] == ("--state-dir", str(tmp_path / "own")) and args["t"] == ("--teacher", "sine")


def test_state_logs_and_recordings_are_beside_the_profile_wherever_up_is_run(tmp_path, monkeypatch):
    profile_file = write(tmp_path, "[profile]\nname='p'\n" + LEARNERS)
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)
    p = load_profile(Path("..") / profile_file.name)
    args = {s.name: p.service_args(s) for s in p.services}
    assert p.log_dir == tmp_path / "runs/p/logs" and p.state_dir == tmp_path / "runs/p/state"
    assert args["l"][-1] == str(tmp_path / "runs/p/state") and args["k"][-1] == str(tmp_path / "own")
    assert args["recorder"][args["recorder"].index("--out") + 1].startswith(str(tmp_path / "runs/p/recordings/"))


def test_up_says_where_state_logs_and_recordings_go(tmp_path):
    p = load_profile(write(tmp_path, "[profile]\nname='p'\nrecord=false\n" + LEARNERS))
    own = identities_dir()
    assert p.where_things_go() == (f"state: {tmp_path}/runs/p/state\nlogs: {tmp_path}/runs/p/logs\n"
                                   f"recordings: not recorded\nsecurity: this user's own identities in {own} "
                                   "(the router at tls/127.0.0.1:7447)")


def test_a_profile_is_secured_by_this_users_own_identities_unless_it_says_off(tmp_path):
    """Loopback let every local user drive the default profile: without zenoh.security a profile now runs
    over TLS on the same port, with identities of this user's own folder."""
    p = load_profile(write(tmp_path, "[zenoh]\nrouter='tcp/127.0.0.1:7600'\nalso_listen=['tcp/127.0.0.1:7601']\n"
                                     + LEARNERS))
    assert (p.security, p.own_security, p.router, p.also_listen) == (
        identities_dir(), True, "tls/127.0.0.1:7600", ("tls/127.0.0.1:7601",))
    off = load_profile(write(tmp_path, "[zenoh]\nsecurity='off'\n" + LEARNERS))
    assert (off.security, off.own_security, off.router) == (None, False, "tcp/127.0.0.1:7447")
    assert "security: off: anyone on this machine may drive the robot" in off.where_things_go()
    with pytest.raises(ProfileError, match='zenoh.security: expected "own" .* got ""'):
        load_profile(write(tmp_path, "[zenoh]\nsecurity=''\n" + LEARNERS))
    with pytest.raises(ProfileError, match="--join: another machine's router shares no CA"):
        load_profile(write(tmp_path, LEARNERS), join="tls/10.0.0.2:7447")


def test_a_services_arguments_are_read_as_its_box_reads_them(tmp_path):
    """They were read as plain strings: `--role=default` made a teacher (the supervisor waited for the
    wrong token and stopped a healthy service) and `--state-dir=/mine` got the profile's added after it."""
    p = load_profile(write(tmp_path, "[services.d]\nbox='demonstrator'\nargs=['--teacher','sine','--role=default']\n"
                                     "[services.m]\nbox='learner'\nargs=['--state-dir=/mine']\n"
                                     "[services.a]\nbox='aibo'\nargs=['--robot=rex']\n"))
    specs = {s.name: s for s in p.services}
    assert specs["d"].role == "default"
    assert p.service_args(specs["m"]) == ("--state-dir=/mine",) and p.state_dir_of(specs["m"]) == Path("/mine")
    assert specs["recorder"].options.robot == ["rex"]


def test_arguments_a_box_refuses_stop_the_profile_at_load_naming_the_service(tmp_path):
    with pytest.raises(ProfileError, match=r"services.l.args: learner refuses them: unrecognized arguments: --sate"):
        load_profile(write(tmp_path, "[services.l]\nbox='learner'\nargs=['--sate-dir','x']\n"))
    with pytest.raises(ProfileError, match=r"services.t.args: .*required: --teacher"):
        load_profile(write(tmp_path, "[services.t]\nbox='demonstrator'\n"))


def test_state_dir_must_be_a_string(tmp_path):
    with pytest.raises(ProfileError, match="profile.state_dir: expected str"):
        load_profile(write(tmp_path, "[profile]\nstate_dir=3\n" + LEARNERS))
