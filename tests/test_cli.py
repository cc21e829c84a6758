"""`dogged`'s global flags (--connect, --profile, --security, --identity) mean the same before the verb and
after it, in both orders docs/security.md and docs/hosts.md show (issue 30): parsed by the real parsers,
nothing started."""
import os
import subprocess
import sys

import pytest

from rigs.harness import REPO
from services import cli
from services.boxes import demonstrator, ui
from services.replay import cli as replay_cli
from services.supervisor import commands

ENDPOINT = "tcp/127.0.0.1:1"  # nothing listens there: nothing in these tests may reach a bus
BUS_FLAGS = ["--connect", ENDPOINT, "--security", "certs", "--identity", "operator.alice"]
ORDERS = ("flags before the verb", "flags after it")


@pytest.fixture(autouse=True)
def environment_restored():
    """--security and --identity set $DOGGED_SECURITY and $DOGGED_IDENTITY for the process: each test starts
    without them and leaves the environment as it found it (monkeypatch.delenv of an absent variable
    restores nothing, and every later test's bus config read the certificates these tests name)."""
    saved = dict(os.environ)
    for name in ("DOGGED_SECURITY", "DOGGED_IDENTITY", "DOGGED_CONNECT"):
        os.environ.pop(name, None)
    yield
    os.environ.clear()
    os.environ.update(saved)


def in_order(order: str, verb: list[str], own: list[str], flags: list[str]) -> list[str]:
    """`dogged FLAGS VERB OWN` or `dogged VERB OWN FLAGS`."""
    return [*flags, *verb, *own] if order == ORDERS[0] else [*verb, *own, *flags]


@pytest.mark.parametrize("box, verb, own, check", [
    (demonstrator, ["run", "demonstrator"], ["--teacher", "mirror"], lambda args: args.teacher == "mirror"),
    (ui, ["ui"], ["--instance", "walk"], lambda args: args.instance == "walk"),
], ids=["run demonstrator", "ui"])
@pytest.mark.parametrize("order", ORDERS)
def test_the_boxes_take_the_bus_flags_before_and_after_the_verb(box, verb, own, check, order, monkeypatch):
    seen = []  # what the box's own parser made of the arguments; its main replaced by a note of them
    monkeypatch.setattr(box, "config_from_args", lambda args: seen.append(args))
    monkeypatch.setattr(box, "main", lambda *args, **kwargs: 0)
    assert cli.main(in_order(order, verb, own, BUS_FLAGS)) == 0
    assert (seen[0].connect, seen[0].cert_dir, seen[0].cert_identity) == ([ENDPOINT], "certs", "operator.alice")
    assert check(seen[0])


@pytest.mark.parametrize("order", ORDERS)
def test_play_is_handed_the_bus_flags_in_either_order(order, monkeypatch):
    seen = []
    monkeypatch.setattr(replay_cli, "play_main", lambda argv: seen.append(argv) or 0)
    assert cli.main(in_order(order, ["play"], ["runs/x"], BUS_FLAGS)) == 0
    assert seen == [["runs/x", *BUS_FLAGS]]


def test_play_takes_the_certificate_flags_too(tmp_path, capsys):
    """Its parser knew --connect only: --security and --identity were unrecognised arguments."""
    assert replay_cli.play_main([str(tmp_path), *BUS_FLAGS]) == 2
    assert "no .mcap files" in capsys.readouterr().err


@pytest.mark.parametrize("verb, own, check", [
    (["ps"], ["--json"], lambda args: args.json),
    (["teach", "on"], ["--teacher", "alice"], lambda args: args.teacher == "alice"),
    (["watch"], ["--bell"], lambda args: args.bell),
    (["logs", "learner"], ["-n", "5"], lambda args: args.lines == 5),
], ids=["ps", "teach on", "watch", "logs"])
@pytest.mark.parametrize("order", ORDERS)
def test_the_supervisor_verbs_take_the_global_flags_before_and_after_the_verb(verb, own, check, order, monkeypatch):
    seen = []
    monkeypatch.setattr(commands, verb[0], lambda args: seen.append(args) or 0)
    assert cli.main(in_order(order, verb, own, [*BUS_FLAGS, "--profile", "robot"])) == 0
    args = seen[0]
    assert (args.connect, args.profile, args.cert_dir, args.cert_identity) == (ENDPOINT, "robot", "certs",
                                                                              "operator.alice")
    assert check(args)


def test_a_flag_given_before_the_verb_is_not_undone_by_the_verbs_defaults(monkeypatch):
    seen = []
    monkeypatch.setattr(commands, "teach", lambda args: seen.append(args) or 0)
    assert cli.main(["--connect", ENDPOINT, "teach", "--security", "certs", "on"]) == 0
    assert (seen[0].connect, seen[0].cert_dir, seen[0].profile) == (ENDPOINT, "certs", None)


@pytest.mark.parametrize("order", ORDERS)
def test_wait_says_how_long_a_verb_tries_to_reach_the_router(order, monkeypatch):
    seen = []
    monkeypatch.setattr(commands, "ps", lambda args: seen.append(args) or 0)
    assert cli.main(in_order(order, ["ps"], [], ["--wait", "2.5"])) == 0
    assert seen[0].wait == 2.5
    assert cli.main(["ps"]) == 0 and seen[1].wait is None  # (the verbs then try for ROUTER_WAIT_S)


@pytest.mark.parametrize("bad", ["0", "-1", "nan", "inf", "3601", "soon"])
def test_a_wait_that_is_not_a_sensible_number_of_seconds_is_refused_naming_the_flag(bad, capsys):
    with pytest.raises(SystemExit) as refused:
        cli.main(["ps", "--wait", bad])
    err = capsys.readouterr().err
    assert refused.value.code == 2 and "argument --wait: expected a finite number" in err, err


def dogged(*argv: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "services.cli", *argv], cwd=REPO, capture_output=True, text=True,
                          timeout=60)


@pytest.mark.live
def test_the_real_cli_hands_connect_before_run_to_the_box():
    """Before the fix: "dogged: error: unrecognized arguments: demonstrator --teacher nosuch"."""
    out = dogged("--connect", ENDPOINT, "run", "demonstrator", "--teacher", "nosuch")
    assert out.returncode == 2
    assert "dogged run demonstrator: error: argument --teacher: invalid choice: 'nosuch'" in out.stderr


@pytest.mark.live
def test_the_real_cli_hands_connect_before_ui_to_the_page():
    """Before the fix: AttributeError: module 'services.supervisor.commands' has no attribute 'ui'."""
    out = dogged("--connect", ENDPOINT, "ui", "--http", "nowhere")
    assert out.returncode == 2
    assert "dogged ui: error: --http must be HOST:PORT" in out.stderr
    assert "Traceback" not in out.stderr
