"""A lossy, jittery link in user space: frames between two interfaces, some dropped, each delayed.

The kernel here has no netem qdisc ("Specified qdisc kind is unknown"), so this process stands in
for it: it sits in its own network namespace between a host's cable and the switch, reads every
Ethernet frame arriving on either side (AF_PACKET) and sends it out of the other one after a random
delay, or drops it. Each direction is impaired on its own, as netem on both ends would; a cut drops
everything, silently, as a radio out of range does (the interfaces stay up).

    python -m rigs.netlab.air A B --loss 0.05 --jitter-ms 20 [--delay-ms 0] [--control FILE]

The control file, if given, is re-read when it changes: `loss jitter_ms delay_ms` (or `cut`).
"""
from __future__ import annotations

import argparse
import heapq
import os
import random
import select
import socket
import sys
import time

ETH_P_ALL = 0x0003
PACKET_OUTGOING = 4  # a frame this socket's interface sent: not to be forwarded back


class Impairment:
    def __init__(self, loss: float = 0.0, jitter_ms: float = 0.0, delay_ms: float = 0.0, cut: bool = False):
        if not (0.0 <= loss <= 1.0 and jitter_ms >= 0 and delay_ms >= 0):
            raise ValueError(f"loss must be 0..1 and delays >= 0, got loss={loss} jitter={jitter_ms} delay={delay_ms}")
        self.loss, self.jitter_s, self.delay_s, self.cut = loss, jitter_ms / 1e3, delay_ms / 1e3, cut

    @classmethod
    def parse(cls, text: str) -> Impairment:
        words = text.split()
        if words == ["cut"]:
            return cls(cut=True)
        loss, jitter, delay = (float(w) for w in (words + ["0", "0", "0"])[:3])
        return cls(loss, jitter, delay)

    def delay(self, rng: random.Random) -> float | None:
        """Seconds this frame waits before it goes on, or None: dropped."""
        if self.cut or rng.random() < self.loss:
            return None
        return self.delay_s + rng.uniform(0.0, self.jitter_s)


def open_tap(interface: str) -> socket.socket:
    tap = socket.socket(socket.AF_PACKET, socket.SOCK_RAW, socket.htons(ETH_P_ALL))
    tap.bind((interface, 0))
    tap.setblocking(False)
    tap.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4 << 20)
    return tap


def relay(a: str, b: str, impairment: Impairment, control: str | None = None, seed: int = 0) -> None:
    rng = random.Random(seed)
    taps = {a: open_tap(a), b: open_tap(b)}
    other = {taps[a].fileno(): taps[b], taps[b].fileno(): taps[a]}
    pending: list[tuple[float, int, socket.socket, bytes]] = []  # (when, order, out, frame)
    order, control_mtime, control_checked = 0, 0.0, 0.0
    print(f"air: {a} <-> {b}", file=sys.stderr, flush=True)
    while True:
        now = time.monotonic()
        if control and now - control_checked > 0.02:
            control_checked = now
            if os.path.exists(control) and os.stat(control).st_mtime_ns != control_mtime:
                control_mtime = os.stat(control).st_mtime_ns
                with open(control) as f:
                    impairment = Impairment.parse(f.read())
        timeout = max(0.0, pending[0][0] - now) if pending else 0.05
        readable, _, _ = select.select(list(taps.values()), [], [], min(timeout, 0.05))
        now = time.monotonic()
        for tap in readable:
            while True:
                try:
                    frame, address = tap.recvfrom(65536)
                except BlockingIOError:
                    break
                if address[2] == PACKET_OUTGOING:
                    continue
                wait = impairment.delay(rng)
                if wait is None:
                    continue
                order += 1
                heapq.heappush(pending, (now + wait, order, other[tap.fileno()], frame))
        while pending and pending[0][0] <= time.monotonic():
            _, _, out, frame = heapq.heappop(pending)
            try:
                out.send(frame)
            except OSError:  # a frame larger than the far side takes, or the link is being torn down: lost
                pass


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("a")
    parser.add_argument("b")
    parser.add_argument("--loss", type=float, default=0.0, help="share of frames dropped, each direction")
    parser.add_argument("--jitter-ms", type=float, default=0.0, help="each frame waits uniform 0..this long")
    parser.add_argument("--delay-ms", type=float, default=0.0, help="and this long besides")
    parser.add_argument("--control", default=None,
                        help="a file of `loss jitter_ms delay_ms` or `cut`, re-read on change")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)
    relay(args.a, args.b, Impairment(args.loss, args.jitter_ms, args.delay_ms), args.control, args.seed)
    return 0


if __name__ == "__main__":
    sys.exit(main())
