"""`dogged demo`: the headline demo, ball seeking end to end as processes over Zenoh."""
from __future__ import annotations

import argparse
import socket
import time
from pathlib import Path


def free_endpoint() -> str:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return f"tcp/127.0.0.1:{s.getsockname()[1]}"


def cli(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="dogged demo", description=__doc__.splitlines()[0])
    parser.add_argument("--learner", default="lwpr")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--episodes", type=int, default=6)
    parser.add_argument("--out", default=None, help="run folder (default runs/<timestamp>)")
    args = parser.parse_args(argv)
    from services.demo.ballseek import run_ballseek_live
    run_dir = Path(args.out or f"runs/{time.strftime('%Y%m%d-%H%M%S')}")
    print(f"dogged demo: ball seeking on a simulated Aibo, all boxes as processes over Zenoh -> {run_dir}/")
    s = run_ballseek_live(run_dir, free_endpoint(), args.learner, args.seed, args.episodes)
    print(f"\nsummary: after {s['taught_s']:.0f} s of teaching, the student alone reached the pink ball in "
          f"{s['successes']} of {s['episodes']} episodes (30 s each, nose within 0.2 m)")
    print(f"  error vs teacher (RMS / half range): {s['error_teaching']:.3f} while taught, "
          f"{s['error_student']:.3f} on its own; {s['ticks']} ticks; {s['wall_s']} s wall")
    print(f"  Figure 5: {s['figure5']}; data: {run_dir / 'run.npz'}; logs: {run_dir / 'logs'}")
    return 0 if s["supervisor_exit"] == 0 else 1
