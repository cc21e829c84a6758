"""One profile's soak, start to end: up, the day, the last pairs caught up, stopped, its recordings checked;
its figures (rigs/soak/report.py prints them)."""
from __future__ import annotations

import json
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rigs.soak import figures as fig
from rigs.soak import records
from rigs.soak.day import Pace, day, pace
from rigs.soak.driver import Driver
from rigs.soak.rig import Rig
from rigs.soak.sample import RecordedSoFar
from rigs.soak.taught import taught_reference, teaching_error
from rigs.soak.watch import LoopWatch
from rigs.harness import free_port
from services.recording.runs import load_run

# the learners swapped through before the wired one comes back, in order; --quick gets to the first two of
# each profile, so between them every registered learner serves (gp and per-output are the two wired)
OTHERS = {"mirroring": ["knn", "lwpr", "sogp", "gp"], "ballseek": ["sogp", "per-output:base=gp", "knn", "lwpr"]}
AFTER_S = 2.0  # a fault's window lasts this long past its end (its last ticks and samples)
BEFORE_S = 1.0  # a kill's begins this long before it: a recorder killed loses its last chunk (flush_s, 0.5 s)
NEVER_BACK_S = 10.0  # the window of a kill whose service never came back (a swap retired it meanwhile)


@dataclass
class ProfileResult:
    name: str
    pace: Pace
    driver: Driver
    growth: list
    check: records.RecordingsCheck
    figures: dict


def rotate_mb(quick: bool) -> float:
    return 0.5 if quick else 4.0


def disk_mb(p: Pace, quick: bool) -> int:
    """The recordings' filesystem: twice what the day records at 8 MB a minute, and room to spare."""
    return 48 if quick else int(2 * 8 * p.length_s / 60) + 64


def fault_windows(d: Driver) -> dict[str, list[tuple[float, float]]]:
    """(start, end) of each fault, time.time(): a kill (from just before it) until its service is back; the
    full disk until the recorder records again; a cut until its link is healed."""
    kills = [(k.at - BEFORE_S, (k.back_at or k.at + NEVER_BACK_S) + AFTER_S) for k in d.kills]
    fills = [(f[0], (f[2] or (f[1] or f[0]) + 15.0) + AFTER_S) for f in d.fills]
    cuts = [(c[0], (c[1] or c[0]) + AFTER_S) for c in d.cuts]
    return {"kills": kills, "fills": fills, "cuts": cuts}


def save_samples(path: Path, d: Driver) -> None:
    """Every sample, each process's figures by name, for reading afterwards (with --out)."""
    rows = [{**{k: v for k, v in vars(row).items() if k != "procs"},
             "procs": {n: vars(p) for n, p in row.procs.items()}} for row in d.rows]
    path.write_text(json.dumps(rows))


def soak_profile(name: str, work: Path, hours: float, quick: bool, keep: bool = False, log=print) -> ProfileResult:
    p = pace(hours, quick)
    rig = Rig(name, work, free_port(), free_port(), rotate_mb(quick), disk_mb(p, quick), log)
    began = time.monotonic()
    try:
        rig.up()
        log(f"{name}: up in {time.monotonic() - began:.1f} s; the day begins ({p.length_s:.0f} s)")
        watch = LoopWatch(rig.run, rig.judge(), rig.profile.name)
        driver = Driver(rig, watch, p, log)
        driver.run(day(p, rig.teachers, rig.killable(), OTHERS[name], rig.wired))
        last = driver.finish()
        watch.close()
        log(f"{name}: the day over after {time.monotonic() - began:.0f} s; stopping")
        rig.stop_profile()
        folder = rig.recordings()
        recorded = RecordedSoFar(folder, watch.keys)
        recorded.update()
        check = records.check(folder, work / "replays")
        log(f"{name}: stopped and its recordings checked after {time.monotonic() - began:.0f} s")
        reference = reference_or_none(folder, rig, watch, name, began, log)  # (before the small disk goes)
        if keep:
            rig.keep(work)
            save_samples(work / "samples.json", driver)
    finally:
        rig.close()
    faults = fault_windows(driver)
    every = faults["kills"] + faults["fills"] + faults["cuts"]
    rate = float(next(s for s in rig.profile.services if s.box == "aibo").options.rate)
    observed = np.array([stamp for stamp, _ in watch.taken.inputs])
    gaps = records.missing_stretches(observed, recorded.stamps(), faults["kills"] + faults["fills"], 1.0 / rate)
    growth = fig.growth(driver.rows, p.warmup_s)
    figures = profile_figures(driver, last, growth, check, gaps, recorded, every, *reference)
    log(f"{name}: done in {time.monotonic() - began:.0f} s")
    return ProfileResult(name, p, driver, growth, check, figures)


def reference_or_none(folder: Path, rig: Rig, watch: LoopWatch, name: str, began: float, log) -> tuple:
    """(taught_reference's error on every recorded pair, and on the program's teachers' alone; what the page
    person taught, judged by teaching_error), logged; None for one with the reason logged if it cannot be had:
    figures beside the others, whose absence must not cost the hour's."""
    try:
        run = load_run(folder)
    except Exception as err:  # noqa: BLE001 - whatever it was, it is said, and the other figures stand
        log(f"{name}: no reference: the recording did not load: {type(err).__name__}: {err}")
        return None, None, None
    judge, out, program = rig.judge(), [], {f"teacher/{t}" for t in rig.teachers}
    for what, sources in (("the", None), ("the program's teachers'", program)):
        try:
            error, pairs = taught_reference(run, rig.wired, judge, watch.taken.judged[1], sources)
        except Exception as err:  # noqa: BLE001 - as above
            log(f"{name}: no reference on {what} recorded pairs: {type(err).__name__}: {err}")
            out.append(None)
            continue
        log(f"{name}: {rig.wired} trained offline on {what} {pairs} recorded pairs, judged on the last span's inputs: "
            f"{error}, after {time.monotonic() - began:.0f} s")
        out.append(error)
    others = set(run.pair_sources.tolist()) - program  # the page person's
    try:
        error, pairs = teaching_error(run, judge, others)
    except Exception as err:  # noqa: BLE001 - as above
        log(f"{name}: no error of what {sorted(others)} taught: {type(err).__name__}: {err}")
        error, pairs = None, 0
    log(f"{name}: what {sorted(others)} taught, {pairs} pairs judged against the program: {error}")
    out.append(error)
    return tuple(out)


def profile_figures(d: Driver, last, growth, check, gaps, recorded, faults,
                    reference: float | None = None, program_reference: float | None = None,
                    person_error: float | None = None) -> dict:
    taken, pairs = d.watch.taken, last.pairs
    first_q, last_q = fig.quarter_p99s(taken.ticks, d.t0, d.pace.length_s, faults)
    errors = fig.alone_errors(taken.errors)
    services = [g for g in growth if g.service != "page"]  # the browser's is the page's own figure
    worst_rss = max(services, key=lambda g: g.rss_mb_per_hour, default=None)
    counted = [g for g in services if g.fds_per_hour is not None]
    worst_fds = max(counted, key=lambda g: g.fds_per_hour, default=None)
    page = next((g for g in growth if g.service == "page"), None)
    heaps = [row.page.get("js_heap_mb") for row in d.rows if row.page.get("js_heap_mb") is not None]
    recorded_pairs = recorded.pairs()
    final = set(last.restarts)  # the services at the end; a killed one missing was replaced by a swap
    replaced = [k for k in d.kills if k.back_at is None and k.service not in final]
    taught_pairs = {(e, s) for e, top in taken.epochs.items() for s in range(1, top + 1)}
    recovered = [k for k in d.kills if k.back_at is not None]
    return {
        "rss_growth_mb_per_hour": worst_rss.rss_mb_per_hour if worst_rss else None,
        "rss_mb_max": max((p.rss_mb for row in d.rows for n, p in row.procs.items() if n != "page"), default=None),
        "rss_grew_mb_max": round(max((g.rss_mb[1] - g.rss_mb[0] for g in services), default=0.0), 2),
        "fds_grew_max": max((g.fds[1] - g.fds[0] for g in counted), default=0),
        "rss_growth_worst": f"{worst_rss.service} (pid {worst_rss.pid})" if worst_rss else None,
        "fd_growth_per_hour": worst_fds.fds_per_hour if worst_fds else None,
        "fd_growth_worst": f"{worst_fds.service} (pid {worst_fds.pid})" if worst_fds else None,
        "tick_p99_ms_first_quarter": first_q, "tick_p99_ms_last_quarter": last_q,
        "pairs_taught": pairs["taught"], "pairs_held": pairs["held"], "pairs_in_memory": pairs["memory"],
        "pairs_in_log": pairs["log"], "pairs_recorded": len(recorded_pairs),
        "pairs_lost": max(0, pairs["taught"] - pairs["held"]) + pairs["lost_by_learner"],
        "pairs_missing_from_recording": len(taught_pairs - recorded_pairs),
        "recording_gaps_s": gaps["outside_s"], "recording_gaps_in_faults_s": gaps["inside_s"],
        "recording_gap_at_s": None if gaps["outside_at"] is None else round(gaps["outside_at"] - d.t0, 1),
        "restarts": last.restarts, "kills": [k.service for k in d.kills],
        "kills_back": len(recovered), "kills_replaced": len(replaced),
        "kills_new_pid": sum(1 for k in d.kills if k.new_pid),
        "kills_not_back": [k.service for k in d.kills if k.back_at is None and k not in replaced],
        "teachers_back_switched_wrong": [k.service for k in d.kills if k.kept_switch is False],
        "back_after_kill_s_max": round(max((k.back_at - k.at for k in recovered), default=0.0), 2),
        "swaps": [s.spec for s in d.swaps if s.tries == 1], "swaps_ok": sum(1 for s in d.swaps if s.ok),
        "swaps_tried_again": sum(1 for s in d.swaps if s.tries > 1),
        "swap_s": [round(s.end - s.at, 1) if s.end is not None else None for s in d.swaps],
        "day_held_s": round(d.held_s, 1),  # the day's clock stopped before its last lesson, for the last swap
        "bursts": len(d.bursts), "burst_refused": sum(b.result.get("refused", 0) for b in d.bursts),
        "burst_got_through": sum(b.result.get("got_through", 0) for b in d.bursts),
        "burst_sessions": sum(sum(bool(w.get("session")) for w in b.result.get("ways", {}).values()
                                  if isinstance(w, dict)) for b in d.bursts),
        "disk_fills": len(d.fills), "recording_again_after_fill": all(f[2] is not None for f in d.fills),
        "cuts": len(d.cuts), "failed_switches": d.failed_switches,
        "recordings": len(check.files), "recordings_open": sum(1 for f in check.files if f.opens and f.replays),
        "recordings_all_open": check.all_open, "recordings_reader": check.reader,
        # why not, where not: a failure in CI says which file and what its reader or replay said
        "recordings_not_open": {f.name: f.said for f in check.files if not (f.opens and f.replays)},
        "run_replay_said": "" if check.run_replays else check.run_said,
        "student_error_first_lesson": round(errors[0], 4) if errors else None,
        "student_error_last": round(errors[-1], 4) if errors else None,
        "student_errors": [round(e, 4) for e in errors],
        # the last span's ticks the learner's answer drove, and those held without it (its answer missed the deadline)
        "student_last_span": fig.last_span_split(taken.errors),
        # the wired learner trained offline on the recorded pairs, judged on the last span's inputs (taught.py)
        "student_error_taught_reference": None if reference is None else round(reference, 4),
        # and on the pairs the program's teachers taught (the page person's left out)
        "student_error_program_reference": None if program_reference is None else round(program_reference, 4),
        # the page person's own pairs judged as the student is: how far from the program the person taught
        "person_taught_error": None if person_error is None else round(person_error, 4),
        "page": last.page, "page_rss_growth_mb_per_hour": page.rss_mb_per_hour if page else None,
        "page_js_heap_mb": (heaps[0], heaps[-1]) if heaps else None, "samples": len(d.rows),
    }
