"""Mirroring spread over hosts (issue 13): network namespaces on one switch (rigs/netlab), the
robot (router, Aibo at 30 Hz, handler), the brain (learner, arbitrator) and two teacher hosts, every
link mutual TLS with access control (rigs/hosts.py). Needs root.

    sudo .venv/bin/python benchmarks/hosts.py [--quick]

1. Tick latency (tick -> command at the robot) with every process on the robot host (no network
   crossed: the baseline) and across hosts (veth, no loss), in turn in the same run.
2. Partitions: a teacher host cut for 3 s and for 12 s (longer than Zenoh's 10-s lease, so its
   session ends and must be opened again), then the brain cut for 3 s.
3. The robot's radio at 5 % loss and 20 ms jitter each way, the brain joined over TLS (TCP) and over
   QUIC (UDP) in turn: tick loss and lateness, then the teaching seconds mirroring needs (both
   teachers on 0.5 s at a time, judged 3 s alone each time, RMS under 0.05 rad on the head).
--quick: 10-s latency windows, one lossy run per transport, no 12-s cut.
Last line: one JSON object (partition_detect_s, partition_heal_s, lossy_ticks_lost_share,
lossy_link_mirror_teach_s, cross_host_tick_p50_ms, loopback_tick_p50_ms, ...).
"""
from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # the repository: rigs.*, benchmarks.*
import services  # noqa: E402,F401  (first: one BLAS thread per process, see services/__init__.py)

import argparse  # noqa: E402
import json  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402

from rigs.hosts import (BRAIN_LINK, LOSSY_DEADLINE_MS, Hosts, Link, brain_partition,  # noqa: E402
                                        loop_window, teach_until_learned, teacher_partition)
from rigs.netlab.lab import available  # noqa: E402

LOSSY = {"loss": 0.05, "jitter_ms": 20.0}


def log(line: str) -> None:
    print(line, file=sys.stderr, flush=True)


def latency(work: Path, colocated: bool, spans: int):
    with Hosts(work, Link(), colocated=colocated) as hosts:
        hosts.wait_ready()
        time.sleep(3.0)  # kernels compiled, the first lessons' refits done
        return loop_window(hosts, spans)


def partitions(work: Path, quick: bool) -> dict:
    with Hosts(work, Link()) as hosts:
        hosts.wait_ready()
        time.sleep(2.0)
        out = {"teacher cut 3 s": teacher_partition(hosts, "alice", cut_s=3.0)}
        log(f"  teacher cut 3 s: {out['teacher cut 3 s']}")
        if not quick:
            out["teacher cut 12 s"] = teacher_partition(hosts, "bob", cut_s=12.0)
            log(f"  teacher cut 12 s: {out['teacher cut 12 s']}")
        out["brain cut 3 s"] = brain_partition(hosts, cut_s=3.0)
        log(f"  brain cut 3 s: {out['brain cut 3 s']}")
        return out


def lossy(work: Path, scheme: str, spans: int):
    with Hosts(work, Link(scheme, **LOSSY), deadline_ms=LOSSY_DEADLINE_MS) as hosts:
        hosts.wait_ready()
        time.sleep(3.0)
        window = loop_window(hosts, spans)
        lesson = teach_until_learned(hosts, step_s=0.5)
        log(f"  {scheme}: {window}, {lesson}")
        return window, lesson


def main(quick: bool) -> dict:
    began = time.monotonic()
    spans, rounds = (1, 1) if quick else (3, 2)
    with tempfile.TemporaryDirectory(prefix="dogged-hosts-") as tmp:
        work = Path(tmp)
        log("latency: one host, then four")
        one_host = latency(work / "one", True, spans)
        wired = latency(work / "wired", False, spans)
        log("partitions")
        cuts = partitions(work / "cuts", quick)
        runs = {scheme: [] for scheme in ("tls", "quic")}
        for k in range(rounds):
            for scheme in runs:
                log(f"lossy radio, brain over {scheme}, round {k + 1}")
                runs[scheme].append(lossy(work / f"{scheme}{k}", scheme, spans))
    teacher_cuts = {k: v for k, v in cuts.items() if k.startswith("teacher")}
    print_latency(one_host, wired, runs)
    print_partitions(teacher_cuts, cuts["brain cut 3 s"])
    print_lessons(runs)
    return {**figures(one_host, wired, teacher_cuts, cuts["brain cut 3 s"], runs),
            "wall_s": round(time.monotonic() - began, 1)}


def print_latency(one_host, wired, runs: dict) -> None:
    print(f"{'deployment':<34} {'ticks':>6} {'lost':>7} {'stale':>7} {'p50 ms':>8} {'p99 ms':>8}")
    print("-" * 74)
    rows = [("one host (no network)", one_host), ("four hosts, veth, no loss", wired)]
    rows += [(f"radio 5%/20ms, brain {scheme} #{k + 1}", w) for scheme, results in runs.items()
             for k, (w, _) in enumerate(results)]
    for name, w in rows:
        print(f"{name:<34} {w.ticks:>6} {w.lost_share:>7.1%} {w.stale_share:>7.1%} {w.latency_p50_ms:>8.2f} "
              f"{w.latency_p99_ms:>8.2f}")
    print(f"cross-host tick p50 {wired.latency_p50_ms:.2f} ms vs one host {one_host.latency_p50_ms:.2f} ms "
          f"(x{wired.latency_p50_ms / one_host.latency_p50_ms:.2f})")
    print()


def print_partitions(teacher_cuts: dict, brain) -> None:
    print(f"{'partition':<18} {'noticed (s)':>12} {'healed (s)':>11} {'commands while cut':>19} {'modes':>16} "
          f"{'restarted':>10}")
    print("-" * 92)
    for name, p in teacher_cuts.items():
        print(f"{name:<18} {_s(p.detect_s):>12} {_s(p.heal_s):>11} {p.commands_while_cut:>19} "
              f"{','.join(sorted(p.modes_while_cut)):>16} {str(p.restarted):>10}")
    print(f"brain cut 3 s: robot held still {brain.held_after - brain.held_before} ticks, head moved "
          f"{brain.head_motion_rad:.5f} rad, {brain.commands_while_cut} commands while cut, loop back "
          f"{_s(brain.resume_s)} s after the heal")
    print()


def print_lessons(runs: dict) -> None:
    print(f"{'lossy radio, brain over':<24} {'taught (s) per run':>20} {'RMS after (rad)':>16} {'rounds':>40}")
    print("-" * 104)
    for scheme, results in runs.items():
        lessons = [lesson for _, lesson in results]
        taught = " ".join(_s(lesson.taught_s if lesson.learned else None) for lesson in lessons)
        errors = " ".join(f"{lesson.error_rad:.4f}" for lesson in lessons)
        print(f"{scheme:<24} {taught:>20} {errors:>16} {str([lesson.rounds for lesson in lessons])[:40]:>40}")
    print(f"targets: noticed under 1 s, healed under 2 s, mirroring under 5 s of teaching over the lossy link "
          f"(the brain joins over {BRAIN_LINK})")


def figures(one_host, wired, teacher_cuts: dict, brain, runs: dict) -> dict:
    chosen = runs[BRAIN_LINK]
    taught = [lesson.taught_s if lesson.learned else float("inf") for _, lesson in chosen]
    return {"partition_detect_s": _worst(p.detect_s for p in teacher_cuts.values()),
            "partition_heal_s": _worst(p.heal_s for p in teacher_cuts.values()),
            "brain_partition_resume_s": brain.resume_s,
            "brain_partition_held_ticks": brain.held_after - brain.held_before,
            "lossy_ticks_lost_share": round(float(np.mean([w.lost_share for w, _ in chosen])), 4),
            "lossy_stale_share": round(float(np.mean([w.stale_share for w, _ in chosen])), 4),
            "lossy_link_mirror_teach_s": round(max(taught), 2),
            "lossy_tick_p50_ms": round(float(np.median([w.latency_p50_ms for w, _ in chosen])), 2),
            "cross_host_tick_p50_ms": round(wired.latency_p50_ms, 3),
            "loopback_tick_p50_ms": round(one_host.latency_p50_ms, 3),
            "cross_host_over_loopback": round(wired.latency_p50_ms / one_host.latency_p50_ms, 2),
            "brain_link": BRAIN_LINK,
            "per_transport": {scheme: {"ticks_lost_share": [round(w.lost_share, 4) for w, _ in results],
                                       "stale_share": [round(w.stale_share, 4) for w, _ in results],
                                       "tick_p50_ms": [w.latency_p50_ms for w, _ in results],
                                       "tick_p99_ms": [w.latency_p99_ms for w, _ in results],
                                       "teach_s": [round(lesson.taught_s, 2) if lesson.learned else None
                                                   for _, lesson in results]}
                              for scheme, results in runs.items()}}


def _s(value) -> str:
    return "-" if value is None else f"{value:.2f}"


def _worst(values) -> float | None:
    values = list(values)
    return None if any(v is None for v in values) else round(max(values), 3)


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="10-s windows, one lossy run per transport, ~2 min")
    quick, reason = parser.parse_args().quick, available()
    if reason:  # make bench runs on any machine: say why there is nothing to measure
        print(f"benchmarks/hosts.py needs network namespaces: {reason}")
        print(json.dumps({"skipped": reason}))
    else:
        print(json.dumps(main(quick)))
