"""Each deploy profile's tick as its user runs it (issue 34).

deploy/<profile>.toml is copied as it is into a scratch folder (its learners' state, logs and recording go
there) and brought up by the supervisor on a router of its own: its platform, wired learner, teachers,
arbitrator, page and recorder. The camera profiles get the pink ball put down where docs/teaching.md's user puts it.
Then a lesson (the teacher switched on, as `dogged teach on` does), then the teacher off while the student
drives. An observer, a peer on the bus as the services are, sees each tick's input, learner proposal and
command; a tick's time is the command's arrival less the input's stamp (the platform's clock as it
published; with a camera, the frame's). The platform receives the very same publication: what the observer
cannot see is the platform's main thread taking it later, which the platform's own status (its latency over
its last 10 s, read at the end of each phase) shows beside.
"""
from __future__ import annotations

import shutil
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from benchmarks.lib.hops import HopObserver, TickSeen, hop_medians_us
from rigs.harness import Probe, free_port
from services.demo.live import BusRecorder, LiveRun, when_ready
from services.profiles import profile_path
from services.supervisor.profile import Profile, ServiceSpec, load_profile

PROFILES = ("mirroring", "ballseek", "hierarchy", "gym")
# what the person switches on to teach: (instance, teacher; "" is every teacher of the instance). Mirroring's
# recorded run in the issue had its one full teacher on; hierarchy teaches both levels at once (docs/hierarchy.md)
LESSONS = {"mirroring": (("main", "mirror"),), "ballseek": (("main", ""),),
           "hierarchy": (("walk", ""), ("seek", "")), "gym": (("main", ""),)}
ARENA = (3, {"pink": [0.9, 0.3], "orange": None})  # docs/teaching.md's `dogged arena --seed 3 --ball pink=0.9,0.3 ...`
SETTLE_S = 1.0  # after a switch, before the phase counts: the teaching token reaches the arbitrator
PHASES = ("teaching", "student")
# each profile as deployed (secured by this user's own identities, the tick path on CPUs of its own), and
# mirroring again right after with security = "off" and with tick_cpus = "off": what security and the placement
# each change in the tick, measured in the same run. (label, profile, [zenoh] security, [profile] tick_cpus)
RUNS = (("mirroring", "mirroring", "", ""), ("mirroring_off", "mirroring", "off", ""),
        ("mirroring_unplaced", "mirroring", "", "off"), *((name, name, "", "") for name in PROFILES[1:]))


@dataclass(frozen=True)
class Phase:
    ticks: list[TickSeen]  # of the instance the platform obeys (the lowest of a chain)
    upper: list[TickSeen]  # of the level above it (hierarchy's seek), else empty
    platform_ms: tuple[float, float]  # the platform's own p50 and p99, over its last 10 s
    taught: int  # pairs the platform's learner had learned by the phase's end
    arbitrators: dict  # level ("lower", "upper") -> its arbitrator's counters' growth over the phase (read
    # from its statuses, each up to a second stale)


def platform_of(profile: Profile) -> ServiceSpec:
    return next(s for s in profile.services if s.box in ("aibo", "platform"))


def hops_of(platform: ServiceSpec) -> int:
    """Bus hops from the platform's tick to its command: input -> learner -> arbitrator -> platform, and
    one more through perception (the camera's frame is the tick) or through a chain (a lower level)."""
    return 3 + (getattr(platform.options, "input_mode", "") == "camera") + bool(platform.options.command_from)


def member(profile: Profile, box: str, instance: str) -> str:
    """The status member (role/name) of the profile's `box` service of `instance`."""
    spec = next(s for s in profile.services if s.box == box and s.instance == instance)
    return f"{spec.role}/{spec.name}"


def watch(name: str, work: Path, seconds: dict[str, float], security: str = "",
          tick_cpus: str = "") -> tuple[Profile, dict[str, Phase]]:
    """Bring the profile up, teach for seconds['teaching'], let the student drive for seconds['student'];
    `security`: its zenoh.security instead of the profile's (the deploy profiles name none: this user's own);
    `tick_cpus`: its profile.tick_cpus instead ("auto" when the profile names none)."""
    variant = (security and f"security-{security}", tick_cpus and f"cpus-{tick_cpus}")
    run_dir = work / "-".join(filter(None, (name, *variant)))
    run_dir.mkdir(parents=True)
    path = run_dir / f"{name}.toml"
    shutil.copy(profile_path(name), path)
    for table, field, value in (("zenoh", "security", security), ("profile", "tick_cpus", tick_cpus)):
        if value:
            text = path.read_text()
            if f"\n[{table}]\n" not in f"\n{text}" or f"\n{field} =" in text:
                raise ValueError(f"deploy/{name}.toml: expected a [{table}] table without {field}, to set it")
            path.write_text(f"\n{text}".replace(f"\n[{table}]\n", f'\n[{table}]\n{field} = "{value}"\n', 1)[1:])
    profile = load_profile(path)
    platform = platform_of(profile)
    lower = platform.options.command_from or platform.instance
    upper = next((i for i, _ in LESSONS[name] if i != lower), None)
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    arbitrators = {level: member(profile, "arbitrator", i) for level, i in (("lower", lower), ("upper", upper)) if i}
    learner = member(profile, "learner", lower)
    run = when_ready(LiveRun(path, run_dir, endpoint, instance=lower))
    steer, observers, probe, phases = {lower: run}, {}, None, {}
    try:  # whatever fails, the profile is stopped: left running it would load every run after
        steer |= {i: BusRecorder(endpoint, i) for i, _ in LESSONS[name] if i != lower}
        observers = {i: HopObserver(endpoint, i) for i in (lower, upper) if i}
        probe = Probe(endpoint)
        if any(s.box == "perception" for s in profile.services):
            run.reset_arena(*ARENA)
        run.run_ticks(int(platform.options.rate), timeout=60)  # a second of the loop running
        probe.wait_for_fresh_status(*arbitrators.values())
        for phase in PHASES:
            for instance, teacher in LESSONS[name]:
                steer[instance].teach(phase == "teaching", teacher)
            time.sleep(SETTLE_S)
            for observer in observers.values():
                observer.start()
            before = {level: dict(probe.status[m].counters) for level, m in arbitrators.items()}
            time.sleep(seconds[phase])
            seen = {i: o.stop() for i, o in observers.items()}
            grown = {level: {k: v - before[level].get(k, 0) for k, v in probe.status[m].counters.items()}
                     for level, m in arbitrators.items()}
            platform_ms = tuple(float(probe.state(f"{platform.role}/{platform.name}", k, np.nan))
                                for k in ("latency_p50_ms", "latency_p99_ms"))
            phases[phase] = Phase(seen[lower], seen.get(upper, []), platform_ms, probe.counter(learner, "learned"),
                                  grown)
    finally:
        if probe is not None:
            probe.close()
        for observer in observers.values():
            observer.close()
        for recorder in steer.values():
            if recorder is not run:
                recorder.close()
        run.close()
        shutil.rmtree(profile.log_dir.parent / "recordings", ignore_errors=True)  # the camera's frames: large
    return profile, phases


def tick_ms(ticks: list[TickSeen]) -> np.ndarray:
    return np.array([t.command_at - t.stamp for t in ticks]) * 1e3


def share(counts: dict, name: str) -> float:
    """The share of the ticks an arbitrator decided that it counted under `name`."""
    return counts.get(name, 0) / counts["commands"] if counts.get("commands") else float("nan")


def summarise(name: str, profile: Profile, phases: dict[str, Phase], floor_rtt_ms: float) -> tuple[list, dict]:
    """Table rows and JSON figures: <name>_tick_p50_ms (the student driving), <name>_tick_p99_ms_teaching, ..."""
    platform = platform_of(profile)
    floor = hops_of(platform) / 2 * floor_rtt_ms
    figures = {f"{name}_rate_hz": platform.options.rate, f"{name}_tick_floor_ms": round(floor, 4)}
    rows = []
    for phase, p in phases.items():
        suffix = "" if phase == "student" else "_teaching"
        for level, ticks in (("lower", p.ticks), ("upper", p.upper)):
            if not ticks:
                continue
            ms, counts, key = tick_ms(ticks), p.arbitrators[level], name + ("_upper" if level == "upper" else "")
            p50, p99 = float(np.percentile(ms, 50)), float(np.percentile(ms, 99))
            without, missed = share(counts, "without_learner"), share(counts, "deadline_misses")
            figures |= {f"{key}_tick_p50_ms{suffix}": round(p50, 3), f"{key}_tick_p99_ms{suffix}": round(p99, 3),
                        f"{key}_without_learner{suffix}": round(without, 4),
                        f"{key}_deadline_misses{suffix}": round(missed, 4)}
            if level == "lower":  # the platform's tick: its own view, its floor, where the time goes
                figures |= {f"{key}_platform_p50_ms{suffix}": round(p.platform_ms[0], 3),
                            f"{key}_platform_p99_ms{suffix}": round(p.platform_ms[1], 3)}
                seen = (p.taught, floor, p.platform_ms, hop_medians_us(ticks, np.array([p.platform_ms[0]])))
            else:
                seen = ("", np.nan, (np.nan, np.nan), {})
            rows.append((name + ("" if level == "lower" else " (upper level)"), phase, seen[0], len(ms), p50, p99,
                         seen[1], seen[2], without, missed, seen[3]))
    return rows, figures


def measure(work: Path, quick: bool, floor_rtt_ms: dict[float, float]) -> tuple[list, dict]:
    """Every profile in turn; `floor_rtt_ms`: the Zenoh round trip's median at each profile's rate."""
    seconds = {"teaching": 10.0, "student": 10.0} if quick else {"teaching": 60.0, "student": 30.0}
    rows, figures = [], {}
    for label, name, security, tick_cpus in RUNS:
        profile, phases = watch(name, work, seconds, security, tick_cpus)
        more_rows, more = summarise(label, profile, phases, floor_rtt_ms[platform_of(profile).options.rate])
        rows += more_rows
        figures |= more
    for suffix in ("", "_teaching"):
        # what security (mutual TLS, access control at every peer) costs the tick
        secured, off = figures["mirroring_tick_p50_ms" + suffix], figures["mirroring_off_tick_p50_ms" + suffix]
        figures["security_tick_p50_ratio" + suffix] = round(secured / off, 3)
        # what the tick path on CPUs of its own (services.placement) changes: placed over unplaced, the platform's
        # own view too (the observer, unplaced, wakes beside the recorder and page)
        for what in ("tick_p50_ms", "tick_p99_ms", "platform_p50_ms", "platform_p99_ms"):
            placed, unplaced = figures[f"mirroring_{what}{suffix}"], figures[f"mirroring_unplaced_{what}{suffix}"]
            figures[f"placement_{what.removesuffix('_ms')}_ratio{suffix}"] = round(placed / unplaced, 3)
    return rows, figures


def rates() -> list[float]:
    """Each profile's tick rate, for the floor measured at the same pace."""
    return sorted({platform_of(load_profile(profile_path(name))).options.rate for name in PROFILES})


def print_table(rows: list) -> None:
    print(f"\n{'profile':<26}{'phase':<10}{'taught':>7}{'ticks':>7}{'p50 ms':>9}{'p99 ms':>9}{'floor':>8}"
          f"{'platform p50/p99':>18}{'no learner':>12}{'missed':>8}   hops (us): to bus, learner, arbitrator, "
          "to platform")
    for name, phase, taught, n, p50, p99, floor, platform_ms, without, missed, hops in rows:
        hop_text = ", ".join(f"{v:.0f}" for v in hops.values())
        print(f"{name:<26}{phase:<10}{taught:>7}{n:>7}{p50:>9.2f}{p99:>9.2f}{floor:>8.2f}"
              f"{platform_ms[0]:>9.2f}/{platform_ms[1]:<8.2f}{without:>12.1%}{missed:>8.1%}   {hop_text}")
    print("taught: pairs its learner had learned by the phase's end; "
          "p50, p99: input stamp -> command seen by an observer on the bus; floor: a Zenoh round trip between two "
          "Python processes at the profile's rate, half of one per hop; platform: its own view over its last "
          "10 s; no learner: ticks its arbitrator decided without the learner's proposal; missed: at the deadline")
