"""One deploy profile brought up for the soak as its user runs it (secured by this user's own identities,
under the supervisor), with what the day needs around it:

- its recordings on a small filesystem of their own (a tmpfs mounted here, as root), so the disk can fill
  and be freed; the recorder rotating files at a small `record_rotate_mb`;
- a second teacher on another host: a network namespace (rigs/netlab) whose cable can be cut, joined to
  the profile's router over TLS with this user's teacher identity (needs root: without it, both lessons are
  the teacher here's, and the run says so);
- the page open in headless chromium the whole run, where a person drives now and then: at mirroring's, arrow
  keys on two leg joints the student is not judged on; at ball seeking's, a gamepad stick held where the
  program's answer is (rigs/live/page.StickPerson).
"""
from __future__ import annotations

import contextlib
import errno
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np

# the test rigs this soak drives (moving out of the product: re-point these imports there)
from services.demo.live import REPO, LiveRun, when_ready
from rigs.live.page import StickPerson
from rigs.netlab.lab import Lab, available

from rigs.soak.watch import Judge
from bus_schema import Spaces, SpacesMessage, decode
from services.bus.queries import ask_owner
from services.experiments.ballseek import ball_spot
from services.experiments.evaluate import half_range
from services.experiments.wiring import wired_spec
from services.profiles import profile_path
from services.own_identities import identities_dir, page_address, person
from services.platforms.aibo.joints import HEAD_PAN, HEAD_TILT
from services.supervisor.profile import load_profile
from services.teachers import make_teacher
from rigs.headless import missing_chromium, open_page
from services.waiting import poll

REMOTE_HOST, REMOTE = "alice", "remote"  # the other host, and its teacher's service name
# per profile: the teacher here, the teacher program (both teachers run it; the student is judged by it),
# the outputs judged (mirroring: the head, which mirrors the tail; the person's keys drive two leg joints)
TEACHERS = {"mirroring": ("mirror", "mirror", [HEAD_PAN, HEAD_TILT]), "ballseek": ("seeker", "ballseek", None)}
PAGE_ADDRESS = '"127.0.0.1:8080"'
MIB = 1 << 20


def profile_text(name: str, ui_port: int, record_dir: Path, rotate_mb: float, also_listen: list[str]) -> str:
    """deploy/<name>.toml as it is, but for its page's port, where and how it records, and the endpoints its
    router listens on besides its own (the other host's way in)."""
    text = profile_path(name).read_text()
    for part in (PAGE_ADDRESS, "[profile]\n", "\n[zenoh]\n"):
        if part not in text:
            raise ValueError(f"deploy/{name}.toml no longer holds {part.strip()!r}: update {__name__}")
    text = text.replace(PAGE_ADDRESS, f'"127.0.0.1:{ui_port}"')
    text = text.replace("[profile]\n", f'[profile]\nrecord_dir = "{record_dir}"\nrecord_rotate_mb = {rotate_mb}\n', 1)
    if also_listen:
        text = text.replace("\n[zenoh]\n", f"\n[zenoh]\nalso_listen = {json.dumps(also_listen)}\n", 1)
    return text


class SmallDisk:
    """A tmpfs of `size_mb` mounted on `folder` (root only; elsewhere a plain folder that never fills)."""

    def __init__(self, folder: Path, size_mb: int, log):
        self.folder, self.ballast, self.mounted = folder, folder / "ballast", False
        folder.mkdir(parents=True, exist_ok=True)
        if os.geteuid() != 0:
            log("not root: the recordings go on this machine's disk, which the soak does not fill")
            return
        subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size_mb}m,mode=0700", "dogged-soak", str(folder)],
                       check=True, capture_output=True)
        self.mounted = True

    def fill(self) -> int:
        """Fill what is left with a ballast file; returns its bytes."""
        if not self.mounted:
            return 0
        written, chunk = 0, bytes(MIB)
        with open(self.ballast, "wb", buffering=0) as f:
            while True:
                try:
                    written += f.write(chunk)
                except OSError as err:
                    if err.errno != errno.ENOSPC:
                        raise
                    break
        return written

    def free(self) -> None:
        self.ballast.unlink(missing_ok=True)

    def close(self) -> None:
        if self.mounted:
            subprocess.run(["umount", str(self.folder)], capture_output=True)
            self.mounted = False


class RandomKeys:
    """A person at the mirroring page: arrow keys held at random, changed twice a second (they drive two
    leg joints, which the mirroring student is not judged on)."""

    def __init__(self, page, seed: int = 0):
        self.page, self.rng, self.held, self.changed = page, np.random.default_rng(seed), set(), -1.0

    def drive(self, x, now: float) -> None:
        if now - self.changed < 0.5:
            return
        self.changed = now
        keys = {k for k in ("ArrowUp", "ArrowDown", "ArrowLeft", "ArrowRight") if self.rng.random() < 0.4}
        for key in sorted(self.held - keys):
            self.page.keyboard.up(key)
        for key in sorted(keys - self.held):
            self.page.keyboard.down(key)
        self.held = keys

    def release(self) -> None:
        for key in sorted(self.held):
            self.page.keyboard.up(key)
        self.held = set()


class Rig:
    """`up()` brings everything up; `stop_profile()` stops the profile (the recorder finishes its files);
    `close()` takes down what is left (the page, the other host, the small disk)."""

    def __init__(self, name: str, work: Path, endpoint_port: int, ui_port: int, rotate_mb: float, disk_mb: int,
                 log=print):
        self.name, self.work, self.log = name, work, log
        self.port, self.ui_port, self.rotate_mb, self.disk_mb = endpoint_port, ui_port, rotate_mb, disk_mb
        self.local, self.program, self.outputs = TEACHERS[name]
        self.stack = contextlib.ExitStack()
        self.run: LiveRun | None = None
        self.lab: Lab | None = None
        self.remote = None  # the other host's teacher process
        self.page = self.person = None
        self.wired = wired_spec(name)

    @property
    def endpoint(self) -> str:
        return f"tls/127.0.0.1:{self.port}"

    def up(self) -> None:
        self.work.mkdir(parents=True, exist_ok=True)
        self.disk = SmallDisk(self.work / "disk", self.disk_mb, self.log)
        self.stack.callback(self.disk.close)
        no_lab = available()
        if no_lab:
            self.log(f"no other host ({no_lab}): both teachers' lessons are the teacher here's, and no link is cut")
        else:
            self.lab = Lab([REMOTE_HOST], observer=True, workdir=str(self.work / "lab"))
            (self.work / "lab").mkdir(exist_ok=True)
            self.stack.enter_context(self.lab)
        also = [f"tcp/10.{self.lab.net}.0.254:{self.port}"] if self.lab else []
        path = self.work / f"{self.name}.toml"
        path.write_text(profile_text(self.name, self.ui_port, self.disk.folder / "recordings", self.rotate_mb, also))
        self.profile = load_profile(path, check_security=False)
        self.run = when_ready(LiveRun(path, self.work, f"tcp/127.0.0.1:{self.port}"))
        self.stack.callback(self.stop_profile)
        self.spaces = self._spaces()
        if self.lab:
            self._start_remote()
        self._open_page()

    def _spaces(self) -> Spaces:
        payload, problem = ask_owner(self.run.session, self.run.keys.spaces, 10.0)
        if payload is None:
            raise RuntimeError(f"the platform's spaces: {problem}")
        return Spaces.from_dict(decode(SpacesMessage, payload, self.run.keys.spaces).spaces)

    def _start_remote(self) -> None:
        argv = [sys.executable, "-m", "services.cli", "run", "demonstrator", "--instance", "main", "--name", REMOTE,
                "--teacher", self.program, "--connect", f"tls/10.{self.lab.net}.0.254:{self.port}",
                "--security", str(identities_dir()), "--identity", f"teacher.{person()}"]
        self.remote = self.lab.run(REMOTE_HOST, argv, log=self.work / "remote.log", cwd=REPO)
        token = self.run.keys.alive("teacher", REMOTE)
        if not poll(lambda: self.remote.poll() is None and any(
                r.ok is not None for r in self.run.session.liveliness().get(token, timeout=1)), 90, 0.5):
            raise RuntimeError(f"the teacher on {REMOTE_HOST} never joined; see {self.work / 'remote.log'}")

    def _open_page(self) -> None:
        missing = missing_chromium()
        if missing:
            self.log(f"no page: {missing}")
            return
        self.page = self.stack.enter_context(open_page(page_address(self.ui_port, wait_s=30)))
        self.page.wait_for_selector("#ears[data-mode]", timeout=60_000)
        self.person = StickPerson(self.page, self.spaces) if self.name == "ballseek" else RandomKeys(self.page)

    # --- what the day asks ------------------------------------------------------------------------
    @property
    def teachers(self) -> tuple[str, str]:
        return self.local, REMOTE if self.lab else self.local

    def judge(self) -> Judge:
        outputs = self.outputs or list(range(self.spaces.output.dims))
        return Judge(make_teacher(self.program, self.spaces), outputs, half_range(self.spaces.output))

    def killable(self) -> list[str]:
        """The services a SIGKILL may hit: the router and every service of the profile (the recorder too)."""
        return ["router"] + [s.name for s in self.profile.services]

    def reset_arena(self, i: int) -> None:
        if any(s.box == "perception" for s in self.profile.services):
            rng = np.random.default_rng(i)
            self.run.reset_arena(i, {"pink": list(ball_spot(rng, arena=i)), "orange": None})

    def page_state(self) -> dict:
        """The page's link ("online" once its socket is up) and its JavaScript heap (MB, as chromium tells)."""
        if self.page is None:
            return {}
        heap = self.page.evaluate("performance.memory ? performance.memory.usedJSHeapSize : -1")
        return {"link": self.page.text_content("#link"), "js_heap_mb": round(heap / 1e6, 2)}

    def recordings(self) -> Path:
        [folder] = list((self.disk.folder / "recordings").iterdir()) or [None]
        return folder

    def state_dir(self) -> Path:
        return self.profile.state_dir

    def stop_profile(self) -> None:
        if self.person is not None:
            with contextlib.suppress(Exception):
                self.person.release()
        if self.run is not None:
            self.run.close()
            self.run = None
        if self.remote is not None and self.remote.poll() is None:
            self.remote.terminate()
            self.remote.wait(30)

    def keep(self, out: Path) -> None:
        """The recordings copied out of the small disk (which goes when the rig closes)."""
        if self.disk.mounted:
            shutil.copytree(self.disk.folder / "recordings", out / "recordings", dirs_exist_ok=True)

    def close(self) -> None:
        self.stack.close()
