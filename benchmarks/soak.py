"""A robot that runs all day (issue 31): deploy/mirroring.toml, then deploy/ballseek.toml, each for --hours
of wall time at its own rate, as its user runs it (secured by this user's own identities, under the
supervisor), under a scripted day (rigs/soak/day.py):

- two teachers switched on and off in turn every few minutes, one on another host (a network namespace,
  rigs/netlab) whose link is cut now and then and restored;
- `dogged swap` of the learner every 10 minutes, through the other registered learners and back;
- a SIGKILL of a service every 5 minutes (the router and the recorder first, then the rest in random order);
- the page open in headless chromium the whole time, a person driving from it now and then;
- a stranger's burst of hostile and malformed messages every 10 minutes: without a certificate, with one of
  its own CA, with one of this user's CA made after the roster was read: the profile runs secured, as
  deployed, so each is refused (at the door, or by access control) and counted; the services' own checks
  of what a member may send are tests/test_fuzz.py's, with security off;
- the recordings on a small filesystem of their own (tmpfs), rotated at a small size, filled once by a
  ballast file and freed.

    .venv/bin/python benchmarks/soak.py [--hours H] [--quick] [--out DIR]

It samples every minute (--quick: every 10 s): each process's resident memory and open file descriptors,
the tick's p50 and p99 (input stamp -> command seen on the bus), the learner's answer time, disk used, the
pairs taught (the arbitrators' numbering) against those the learner holds (its status, its model, its pair
log) and those recorded, and the student's error while alone (the teacher's program on the same inputs:
the paper's measure). Shorter than an hour, every period of the day shrinks with it; --quick: a minute of
each profile holding one of each thing. Network namespaces and the tmpfs need root; without it those parts
are skipped, saying so. The last line is one JSON object: rss_growth_mb_per_hour (the worst process,
after its first 10 minutes), fd_growth_per_hour, tick_p99_ms_first_quarter and tick_p99_ms_last_quarter
(per profile), pairs_lost, recording_gaps_s (outside the faults), restarts (by service),
student_error_first_lesson and student_error_last (per profile), student_error_taught_reference (the wired
learner trained offline on the recorded pairs, judged on the last span's inputs: what the teaching alone makes of
the student), student_error_program_reference (the same, on the pairs the program's teachers taught: the
page person's keys left out), recordings_all_open, and each profile's figures under "profiles". Targets (reported, not
asserted): no process grows more than 20 MB an hour, no file descriptor leak, last-quarter p99 within 1.2x the
first's, 0 pairs lost, every recording opens, the student alone at the end as good as after its first lesson.
"""
from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # the repository: services.*, rigs.harness
import services  # noqa: E402,F401  (first: one BLAS thread per process, see services/__init__.py)

import argparse  # noqa: E402
import json  # noqa: E402
import signal  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402

from rigs.soak.report import print_report, summary  # noqa: E402
from rigs.soak.run import soak_profile  # noqa: E402

PROFILES = ("mirroring", "ballseek")


def stop_on_sigterm() -> None:
    """A SIGTERM ends the soak as Ctrl-C does: every profile stopped, the small disk unmounted."""
    def stop(*_):
        raise KeyboardInterrupt
    signal.signal(signal.SIGTERM, stop)


def main(hours: float, quick: bool, out: str | None, profiles=PROFILES) -> dict:
    began = time.monotonic()
    stop_on_sigterm()
    with tempfile.TemporaryDirectory(prefix="dogged-soak-") as tmp:
        work = Path(out) if out else Path(tmp)
        results = {name: soak_profile(name, work / name, hours, quick, keep=bool(out),
                                      log=lambda line: print(line, file=sys.stderr, flush=True))
                   for name in profiles}
    print_report(results)
    figures = summary(results)
    figures["wall_s"] = round(time.monotonic() - began, 1)
    return figures


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--hours", type=float, default=1.0, help="each profile's wall time (default 1)")
    parser.add_argument("--quick", action="store_true", help="a minute of each profile (about 3 minutes in all)")
    parser.add_argument("--out", default=None, help="keep everything (logs, recordings) in this folder")
    parser.add_argument("--profile", action="append", choices=PROFILES, default=None, help="only this one (repeatable)")
    args = parser.parse_args()
    if args.hours <= 0:
        parser.error("--hours must be > 0")
    print(json.dumps(main(args.hours, args.quick, args.out, tuple(args.profile or PROFILES))))
