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
    parser.add_argument("--learner", default=None, help="default: as deploy/ballseek.toml wires it")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--episodes", type=int, default=6, help="student-only pink episodes (default 6)")
    parser.add_argument("--orange-episodes", type=int, default=3,
                        help="orange-only episodes before and after the correction "
                             "(default 3; 0 skips the orange ball)")
    parser.add_argument("--answer-unsure", type=float, default=0.0, metavar="P",
                        help="between lessons, the scripted person answers the robot's requests (green ears) "
                             "with probability P")
    parser.add_argument("--out", default=None, help="run folder (default runs/<timestamp>)")
    args = parser.parse_args(argv)
    if not 0.0 <= args.answer_unsure <= 1.0:
        parser.error(f"--answer-unsure is a probability in [0, 1], got {args.answer_unsure}")
    from services.demo.ballseek import run_ballseek_live
    from services.experiments.evaluate import percent
    run_dir = Path(args.out or f"runs/{time.strftime('%Y%m%d-%H%M%S')}")
    print(f"dogged demo: ball seeking on a simulated Aibo, all boxes as processes over Zenoh -> {run_dir}/")
    s = run_ballseek_live(run_dir, free_endpoint(), args.learner, args.seed, args.episodes,
                          orange_episodes=args.orange_episodes, answer_probability=args.answer_unsure)
    print(f"\nsummary: after {s['taught_s']:.0f} s of teaching, the student alone reached the pink ball in "
          f"{s['successes']} of {s['episodes']} episodes (30 s each, nose within 0.2 m)")
    if args.orange_episodes:
        print(f"  the orange ball, never taught: approached in {s['orange_before']} of {s['orange_episodes']} "
              f"episodes; after a 20 s correction, in {s['orange_after']} of {s['orange_episodes']}")
        print(f"  asked for teaching (green ears) with the orange ball in view: {percent(s.get('asks_orange_before'))} "
              f"of the student's ticks before the correction, {percent(s.get('asks_orange_after'))} after; "
              f"with pink in view: {percent(s.get('asks_student'))}")
    errors = f"{s['error_teaching']:.3f} while taught, {s['error_student']:.3f} alone with pink"
    if args.orange_episodes:
        errors += f", {s['error_orange_before']:.3f} with orange before correction, {s['error_orange_after']:.3f} after"
    print(f"  Figure 5, student vs teacher (RMS / half range): {errors}; {s['ticks']} ticks; {s['wall_s']} s wall")
    print(f"  plot: {s['figure5_png']}; data: {run_dir / 'run.npz'}, {run_dir / 'summary.json'}; "
          f"logs: {run_dir / 'logs'}")
    return 0 if s["supervisor_exit"] == 0 else 1
