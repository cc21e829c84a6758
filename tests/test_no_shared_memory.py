"""No Zenoh shared memory between our processes. With it (Zenoh's default), a payload over 3 KiB between
two processes of a machine went through the sender's 16 MiB pool, which the receiver mapped (2 fds) and
kept mapped after the sender died, its file left in /dev/shm: the soak's camera readers grew 19.4 MB and 2
fds at each restart of the Aibo (benchmarks/soak.py)."""
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from rigs.harness import REPO, free_port
from services.bus.config import zenoh_config

SUBSCRIBER = r'''
import sys, time, zenoh
from services.bus.config import zenoh_config
heard = [0]
with zenoh.open(zenoh_config(connect=[sys.argv[1]], mode="peer", listen=[sys.argv[2]])) as s:
    sub = s.declare_subscriber("dl/main/camera", lambda sample: heard.__setitem__(0, heard[0] + 1))
    while True:
        time.sleep(0.2)
'''
CAMERA = r'''
import sys, time, zenoh
from services.bus.config import zenoh_config
with zenoh.open(zenoh_config(connect=[sys.argv[1]], mode="peer", listen=[sys.argv[2]])) as s:
    pub = s.declare_publisher("dl/main/camera")
    while True:
        pub.put(b"x" * 300_000)
        time.sleep(1 / 15)
'''


def test_our_sessions_use_no_shared_memory():
    conf = zenoh_config(connect=["tcp/127.0.0.1:7447"])
    assert json.loads(conf.get_json("transport/shared_memory/enabled")) is False


def rss_mb_and_fds(pid: int) -> tuple[float, int]:
    rss = next(int(line.split()[1]) / 1024 for line in open(f"/proc/{pid}/status") if line.startswith("VmRSS"))
    return rss, len(os.listdir(f"/proc/{pid}/fd"))


@pytest.mark.live
@pytest.mark.skipif(not Path("/proc/self/fd").exists(), reason="reads fds from /proc")
def test_a_camera_killed_and_restarted_leaves_its_reader_as_it_was():
    port = free_port()
    router_ep = f"tcp/127.0.0.1:{port}"
    quiet = dict(cwd=REPO, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    router = subprocess.Popen([sys.executable, "-m", "services.cli", "run", "router", "--listen", router_ep], **quiet)
    reader = subprocess.Popen([sys.executable, "-c", SUBSCRIBER, router_ep, f"tcp/127.0.0.1:{free_port()}"],
                              **quiet)
    try:
        seen = []
        for _ in range(4):
            camera = subprocess.Popen([sys.executable, "-c", CAMERA, router_ep, f"tcp/127.0.0.1:{free_port()}"],
                                      **quiet)
            time.sleep(2.5)
            camera.send_signal(signal.SIGKILL)
            camera.wait()
            time.sleep(0.5)
            seen.append(rss_mb_and_fds(reader.pid))
        (rss0, fds0), (rss1, fds1) = seen[0], seen[-1]
        # with shared memory: +2 fds and +19.4 MB at every restart
        assert fds1 == fds0 and rss1 - rss0 < 10, seen
    finally:
        for p in (reader, router):
            p.terminate()
            p.wait(10)
