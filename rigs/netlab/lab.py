"""Separate machines on one Linux box: each host a network namespace with one cable to a switch.

    with Lab(["robot", "brain", "alice"], radio="robot") as lab:
        lab.run("robot", ["python", "-m", "services.cli", "run", "router", ...])
        lab.cut("alice"); lab.heal("alice")          # a partition: frames vanish, links stay up
        lab.impair("robot", loss=0.05, jitter_ms=20)  # the robot's radio link

Hosts get 10.<net>.0.<n>/24 on `eth0` (net: the first from 77 no lab holds, routed nowhere) and
their own loopback. The switch is a bridge in a namespace of its own; a cut takes the host's port
off the bridge (the cable stays plugged in and up), so nothing reaches either side and neither side
is told, as when a machine walks out of range. The host named `radio` is cabled through
rigs/netlab/air.py instead, in a namespace between it and the switch, so its link can drop and
delay frames. With `observer`, this process's own namespace is on the switch too, at
10.<net>.0.254, to watch the hosts as one more machine would. Closing ends every process left in
the lab's namespaces. Needs root and iproute2 (`ip`); `available()` says whether this machine can.
"""
from __future__ import annotations

import fcntl
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import IO
from services.waiting import poll

ROOT = Path(__file__).resolve().parents[2]


def available() -> str:
    """"" if namespaces can be made here, else why not."""
    if os.geteuid() != 0:
        return "network namespaces need root"
    if shutil.which("ip") is None:
        return "iproute2 (`ip`) is not installed"
    probe = f"dlprobe{os.getpid()}"
    made = subprocess.run(["ip", "netns", "add", probe], capture_output=True, text=True)
    if made.returncode != 0:
        return f"ip netns add failed: {made.stderr.strip()}"
    subprocess.run(["ip", "netns", "del", probe], capture_output=True)
    return ""


def sweep_stale_labs() -> None:
    """Delete what labs of processes no longer alive left behind (namespaces dl<pid>-*, cables dl<pid>o):
    a lab killed before its close() would otherwise keep its addresses, and the next lab's would clash."""
    names = subprocess.run(["ip", "netns", "list"], capture_output=True, text=True).stdout.split()
    links = [line.split(":")[1].strip().split("@")[0] for line in
             subprocess.run(["ip", "-o", "link"], capture_output=True, text=True).stdout.splitlines()]
    for name in names + links:
        match = re.fullmatch(r"dl(\d+)n\d+(-[a-z0-9]+|o)", name)
        if match and not _alive(int(match.group(1))):
            if match.group(2) == "o":
                subprocess.run(["ip", "link", "del", name], capture_output=True)
            else:
                end_namespaces([name])


def end_namespaces(names) -> None:
    """Stop every process still inside the namespaces (whoever started them), then delete them."""
    names = list(names)
    pids = {int(p) for name in names for p in
            subprocess.run(["ip", "netns", "pids", name], capture_output=True, text=True).stdout.split()}
    for sig in (signal.SIGTERM, signal.SIGKILL):
        for pid in pids:
            try:
                os.kill(pid, sig)
            except ProcessLookupError:
                pass
        poll(lambda: not any(_alive(pid) for pid in pids), 5, 0.05)
    for name in names:
        subprocess.run(["ip", "netns", "del", name], capture_output=True)


NET_CLAIMS = Path(tempfile.gettempdir()) / "dogged-netlab-nets"  # a lock file per 10.<net> a lab of this machine holds


def claim_net(first: int = 77) -> tuple[int, IO]:
    """A 10.<net>.0.0/24 this machine routes nowhere yet (another lab's observer would claim one) and no other lab
    holds: the net and its lock, held until the lab closes it. Two labs built at the same moment (two soaks side by
    side) chose the same net from the routes alone, before either had routed it."""
    routes = subprocess.run(["ip", "-4", "route"], capture_output=True, text=True).stdout
    NET_CLAIMS.mkdir(exist_ok=True)
    for net in list(range(first, 255)) + list(range(1, first)):
        if f"10.{net}." in routes:
            continue
        lock = open(NET_CLAIMS / f"{net}.lock", "w")
        try:
            fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:  # another lab's
            lock.close()
            continue
        return net, lock
    raise RuntimeError("every 10.<n>.0.0/24 is routed or held already")


def _alive(pid: int) -> bool:
    """Running (not gone, not a zombie waiting to be reaped)."""
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] != "Z"
    except (OSError, IndexError):
        return False


def _ip(*args: str, ns: str | None = None) -> None:
    command = ["ip", *(["-n", ns] if ns else []), *args]
    done = subprocess.run(command, capture_output=True, text=True)
    if done.returncode != 0:
        raise RuntimeError(f"{' '.join(command)}: {done.stderr.strip()}")


class Lab:
    _made_here = 0

    def __init__(self, hosts: list[str], radio: str | None = None, net: int | None = None, workdir: str | None = None,
                 observer: bool = False):
        if radio is not None and radio not in hosts:
            raise ValueError(f"radio host {radio!r} is not one of {hosts}")
        Lab._made_here += 1  # sweep_stale_labs() reads the pid back; the count tells this process's labs apart
        self.tag = f"dl{os.getpid()}n{Lab._made_here}"
        self._claim = None  # the lock holding a net chosen here (claim_net), released at close
        if net is None:
            net, self._claim = claim_net()
        self.hosts, self.radio, self.net = list(hosts), radio, net
        self.address = {h: f"10.{net}.0.{i + 1}" for i, h in enumerate(hosts)}
        self.dir = Path(workdir or tempfile.mkdtemp(prefix="netlab-"))
        self.observer = observer  # this (the root) namespace on the switch too, at 10.<net>.0.254
        self.procs: list[subprocess.Popen] = []
        self.air: subprocess.Popen | None = None
        self._made: list[str] = []

    def ns(self, host: str) -> str:
        return f"{self.tag}-{host}"

    @property
    def switch(self) -> str:
        return f"{self.tag}-switch"

    @property
    def air_ns(self) -> str:
        return f"{self.tag}-air"

    def port(self, host: str) -> str:
        """The host's port on the switch (an interface name: 15 characters at most)."""
        return f"p{self.hosts.index(host)}"

    # --- building and tearing down -----------------------------------------------------------
    def __enter__(self) -> Lab:
        sweep_stale_labs()
        try:
            self._build()
        except BaseException:
            self.close()
            raise
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def _netns(self, name: str) -> None:
        _ip("netns", "add", name)
        self._made.append(name)
        _ip("link", "set", "lo", "up", ns=name)

    def _build(self) -> None:
        self._netns(self.switch)
        _ip("link", "add", "br0", "type", "bridge", ns=self.switch)
        _ip("link", "set", "br0", "up", ns=self.switch)
        for host in self.hosts:
            self._netns(self.ns(host))
            outer = "air-sw" if host == self.radio else self.port(host)
            _ip("link", "add", "eth0", "netns", self.ns(host), "type", "veth", "peer", "name", outer,
                "netns", self.switch if host != self.radio else self._air())
            _ip("addr", "add", f"{self.address[host]}/24", "dev", "eth0", ns=self.ns(host))
            _ip("link", "set", "eth0", "up", ns=self.ns(host))
            if host == self.radio:
                self._cable_through_air(host)
            else:
                self._attach(self.port(host))
        if self.radio:
            self.impair(self.radio)
        if self.observer:  # this namespace's end of the cable goes in close()
            _ip("link", "add", f"{self.tag}o", "type", "veth", "peer", "name", "po", "netns", self.switch)
            _ip("addr", "add", f"10.{self.net}.0.254/24", "dev", f"{self.tag}o")
            _ip("link", "set", f"{self.tag}o", "up")
            self._attach("po")

    def _air(self) -> str:
        if self.air_ns not in self._made:
            self._netns(self.air_ns)
            # the air forwards frames; its own kernel must not answer or send anything
            subprocess.run(["ip", "netns", "exec", self.air_ns, "sysctl", "-qw", "net.ipv6.conf.all.disable_ipv6=1"],
                           capture_output=True)
        return self.air_ns

    def _cable_through_air(self, host: str) -> None:
        _ip("link", "add", "air-up", "type", "veth", "peer", "name", self.port(host), "netns", self.switch,
            ns=self.air_ns)
        for side in ("air-sw", "air-up"):
            _ip("link", "set", side, "promisc", "on", "up", ns=self.air_ns)
        self._attach(self.port(host))
        # both ends that send into the air fill in their own checksums (rigs/netlab/offload.py)
        for ns, interface in ((self.ns(host), "eth0"), (self.switch, self.port(host))):
            subprocess.run(["ip", "netns", "exec", ns, sys.executable, "-m", "rigs.netlab.offload", interface],
                           check=True, cwd=ROOT)
        self.control = self.dir / "air.control"
        self.control.write_text("0 0 0")
        self.air = subprocess.Popen(["ip", "netns", "exec", self.air_ns, sys.executable, "-m", "rigs.netlab.air",
                                     "air-sw", "air-up", "--control", str(self.control)],
                                    stdout=subprocess.DEVNULL, stderr=open(self.dir / "air.log", "w"),
                                    cwd=ROOT)

    def _attach(self, port: str) -> None:
        _ip("link", "set", port, "master", "br0", ns=self.switch)
        _ip("link", "set", port, "up", ns=self.switch)

    def close(self) -> None:
        for proc in self.procs + ([self.air] if self.air else []):
            if proc.poll() is None:
                proc.terminate()
        for proc in self.procs + ([self.air] if self.air else []):
            try:
                proc.wait(10)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()
        end_namespaces(reversed(self._made))
        self._made.clear()
        if self.observer:  # a namespace outlives its name while any socket in it lingers; so would this cable
            subprocess.run(["ip", "link", "del", f"{self.tag}o"], capture_output=True)
        if self._claim is not None:
            self._claim.close()
            self._claim = None

    # --- using it ------------------------------------------------------------------------------
    def command(self, host: str, argv: list[str]) -> list[str]:
        """`argv` as run on `host`: inside its namespace, with DOGGED_HOST naming the machine."""
        return ["ip", "netns", "exec", self.ns(host), "env", f"DOGGED_HOST={host}", *argv]

    def run(self, host: str, argv: list[str], log: str | Path | None = None, **popen) -> subprocess.Popen:
        """Start `argv` on `host` (stdout and stderr to `log`); stopped by close()."""
        out = open(log, "ab") if log else subprocess.DEVNULL
        proc = subprocess.Popen(self.command(host, argv), stdout=out, stderr=subprocess.STDOUT, **popen)
        self.procs.append(proc)
        return proc

    def cut(self, host: str) -> None:
        """The host's frames stop reaching the switch, and the switch's stop reaching it; no one is told."""
        _ip("link", "set", "dev", self.port(host), "nomaster", ns=self.switch)  # off the bridge, still up

    def heal(self, host: str) -> None:
        self._attach(self.port(host))

    def impair(self, host: str, loss: float = 0.0, jitter_ms: float = 0.0, delay_ms: float = 0.0) -> None:
        """The radio host's link: each frame, each way, dropped with probability `loss`, else held
        `delay_ms` plus uniform 0..`jitter_ms`."""
        if host != self.radio:
            raise ValueError(f"only the radio host ({self.radio}) has an impairable link")
        tmp = self.control.with_suffix(".tmp")
        tmp.write_text(f"{loss} {jitter_ms} {delay_ms}")
        tmp.replace(self.control)
        time.sleep(0.1)  # the air re-reads it within 20 ms
