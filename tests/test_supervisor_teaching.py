"""A teacher restarted by the supervisor comes back as the person left it (issue 12): the switch is
read from its teaching token, and a token that vanished with its process died teaching."""
import time

from services.supervisor.process import ManagedProcess
from services.supervisor.profile import load_profile
from services.supervisor.supervisor import Supervisor

PROFILE = """
[services.mirror]
box = "demonstrator"
args = ["--teacher", "mirror"]

[services.always]
box = "demonstrator"
args = ["--teacher", "sine", "--on"]
"""
TOKEN = "dl/main/alive/teaching/{}"


def supervisor(tmp_path):
    path = tmp_path / "teach.toml"
    path.write_text(PROFILE)
    sup = Supervisor(load_profile(path), echo=False)
    for spec in sup.profile.services:
        sup.procs[spec.name] = ManagedProcess(spec, sup.command_for(spec), tmp_path, echo=False)
    return sup


def comes_back_on(sup, name, died_after_event: float | None) -> bool:
    proc = sup.procs[name]
    proc.died_at = time.monotonic() + (died_after_event or 0.0)
    return "--on" in sup.restart_command(proc)


def test_a_teacher_that_died_teaching_comes_back_teaching(tmp_path):
    sup = supervisor(tmp_path)
    sup.note_teaching(TOKEN.format("mirror"), True)
    assert comes_back_on(sup, "mirror", 0.0)
    sup.note_teaching(TOKEN.format("mirror"), False)  # its token went with it
    assert comes_back_on(sup, "mirror", 0.05)


def test_a_teacher_switched_off_before_it_died_comes_back_off(tmp_path):
    sup = supervisor(tmp_path)
    sup.note_teaching(TOKEN.format("mirror"), True)
    sup.note_teaching(TOKEN.format("mirror"), False)
    assert not comes_back_on(sup, "mirror", 5.0)
    sup.note_teaching(TOKEN.format("always"), False)  # its profile said --on; the person said off
    assert not comes_back_on(sup, "always", 5.0)


def test_without_a_record_the_profile_decides(tmp_path):
    sup = supervisor(tmp_path)
    assert comes_back_on(sup, "always", None) and not comes_back_on(sup, "mirror", None)
    sup.note_teaching(TOKEN.format("stranger"), True)  # not a service of this profile: ignored
    assert "stranger" not in sup.teaching
