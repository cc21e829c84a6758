"""The soak's table (each profile's samples, its processes' growth, its events, its recordings) and its last
line's figures: the worst or the sum over the profiles, each profile's own under "profiles"."""
from __future__ import annotations


def _fmt(v, spec: str = ".2f", width: int = 8) -> str:
    return f"{'-':>{width}}" if v is None else f"{v:>{width}{spec}}"


def cpu_share(before, after, names=None) -> float | None:
    """The CPU (% of one core) the processes of `after` (those `names`) had since `before`, each that kept its pid."""
    if before is None or after.t <= before.t:
        return None
    spent = sum(p.cpu_s - before.procs[n].cpu_s for n, p in after.procs.items()
                if (names is None or n in names) and n in before.procs and before.procs[n].pid == p.pid)
    return 100.0 * spent / (after.t - before.t)


def print_samples(result) -> None:
    print(f"\n{result.name}: {result.pace.length_s:.0f} s, a sample every {result.pace.sample_s:g} s")
    print(f"{'t s':>7}{'tick p50':>9}{'p99':>8}{'answer':>8}{'p99':>8}{'error':>8}{'taught':>8}{'held':>7}"
          f"{'log':>7}{'memory':>7}{'recorded':>9}{'rec MB':>8}{'disk MB':>8}{'RSS MB':>8}{'fds':>6}{'CPU %':>7}"
          f"{'page':>6}{'restarts':>9}  heaviest")
    before = None
    for row in result.driver.rows:
        services = [n for n in row.procs if n != "page"]
        cpu, page_cpu = cpu_share(before, row, services), cpu_share(before, row, ["page"])
        before = row
        pairs = row.pairs
        heaviest = max(row.procs.items(), key=lambda kv: kv[1].rss_mb, default=("", None))
        print(f"{row.t:>7.0f}{_fmt(row.tick_ms[0], '.2f', 9)}{_fmt(row.tick_ms[1])}{_fmt(row.answer_ms[0])}"
              f"{_fmt(row.answer_ms[1])}{_fmt(row.error, '.4f')}{pairs['taught']:>8}{pairs['held']:>7}{pairs['log']:>7}"
              f"{pairs['memory']:>7}{pairs['recorded']:>9}{row.disk['recordings']:>8.1f}{row.disk['filesystem']:>8.1f}"
              f"{sum(row.procs[n].rss_mb for n in services):>8.0f}{sum(row.procs[n].fds for n in services):>6}"
              f"{_fmt(cpu, '.0f', 7)}{_fmt(page_cpu, '.0f', 6)}{sum(row.restarts.values()):>9}  {heaviest[0]} "
              f"{'' if heaviest[1] is None else f'{heaviest[1].rss_mb:.0f} MB'}")
    print("tick: input stamp -> command seen on the bus (ms); answer: input -> the learner's proposal, as seen; "
          "error: the student's alone (RMS of (teacher program - command) / half range); pairs: taught (numbered by "
          "the arbitrators), held (the learner's status), log (its pair log), memory (its model), recorded; RSS, fds, "
          "CPU (% of a core): the profile's processes; page: the browser's CPU")


def print_growth(result) -> None:
    print(f"\n{result.name}: each process after its first {result.pace.warmup_s:.0f} s (a restart is a new pid; "
          "a service with the processes it spawned)")
    print(f"{'process':<22}{'pid':>8}{'RSS MB':>16}{'MB/h':>9}{'fds':>12}{'fds/h':>8}{'samples':>9}"
          f"{'for fds':>9}")
    for g in sorted(result.growth, key=lambda g: -g.rss_mb_per_hour):
        fds = "-" if g.fds_per_hour is None else f"{g.fds[0]}->{g.fds[1]}"
        per_hour = "-" if g.fds_per_hour is None else f"{g.fds_per_hour:.1f}"
        print(f"{g.service:<22}{g.pid:>8}{g.rss_mb[0]:>8.1f}->{g.rss_mb[1]:<6.1f}{g.rss_mb_per_hour:>9.1f}"
              f"{fds:>12}{per_hour:>8}{g.points:>9}{g.fd_points:>9}")
    print("fds: over the samples in which the bus had its usual members (a swap's new learner catching up beside "
          "the old one is one more peer: two more sockets in every process while both live)")


def print_events(result) -> None:
    d, f = result.driver, result.figures
    print(f"\n{result.name}: kills {', '.join(f['kills']) or 'none'}: {f['kills_back']} back (token), "
          f"{f['kills_replaced']} replaced by a swap meanwhile, {f['kills_new_pid']} with a new pid in ps, the "
          f"slowest after {f['back_after_kill_s_max']} s; swaps {', '.join(f['swaps']) or 'none'}: {f['swaps_ok']} "
          f"ok ({f['swaps_tried_again']} asked again) in {f['swap_s']} s, the day waiting {f['day_held_s']} s for "
          f"the last before its last lesson; "
          f"stranger bursts {f['bursts']}: {f['burst_sessions']} sessions opened, {f['burst_refused']} refusals "
          f"counted, {f['burst_got_through']} payloads got through; disk filled {f['disk_fills']}x, recording "
          f"again after: {f['recording_again_after_fill']}; links cut {f['cuts']}x; switches retried "
          f"{f['failed_switches']}")
    for swap in d.swaps:
        if not swap.ok:
            print(f"  swap to {swap.spec} failed: {swap.said}")
    print(f"pairs: taught {f['pairs_taught']}, held {f['pairs_held']} (log {f['pairs_in_log']}, model "
          f"{f['pairs_in_memory']}), recorded {f['pairs_recorded']} ({f['pairs_missing_from_recording']} missing); "
          f"lost {f['pairs_lost']}; recording gaps: {f['recording_gaps_s']} s outside the faults, "
          f"{f['recording_gaps_in_faults_s']} s inside; student error alone per span {f['student_errors']}; "
          f"the last span's ticks the learner drove and those held without it: {f['student_last_span']}; "
          f"the wired learner trained offline on the recorded pairs, on the last span's inputs: "
          f"{f['student_error_taught_reference']}; on the program's teachers' pairs alone (the person's left out): "
          f"{f['student_error_program_reference']}; the page person's own pairs against the program: "
          f"{f['person_taught_error']}")


def print_recordings(result) -> None:
    check = result.check
    print(f"\n{result.name}: {len(check.files)} recordings ({check.reader}; `dogged replay` of each and of the run: "
          f"{'ok' if check.run_replays else 'FAILED: ' + check.run_said})")
    for f in check.files:
        if not (f.opens and f.replays) or not f.finished:
            print(f"  {f.name}: {f.mb} MB, finished {f.finished}, opens {f.opens}, replays {f.replays}: {f.said}")


def print_report(results: dict) -> None:
    for result in results.values():
        print_samples(result)
        print_growth(result)
        print_events(result)
        print_recordings(result)


def summary(results: dict) -> dict:
    per = {name: r.figures for name, r in results.items()}

    def worst(key):
        values = [f[key] for f in per.values() if f[key] is not None]
        return max(values) if values else None
    return {"rss_growth_mb_per_hour": worst("rss_growth_mb_per_hour"),
            "fd_growth_per_hour": worst("fd_growth_per_hour"),
            "tick_p99_ms_first_quarter": {n: f["tick_p99_ms_first_quarter"] for n, f in per.items()},
            "tick_p99_ms_last_quarter": {n: f["tick_p99_ms_last_quarter"] for n, f in per.items()},
            "pairs_lost": sum(f["pairs_lost"] for f in per.values()),
            "recording_gaps_s": worst("recording_gaps_s"),
            "restarts": {f"{n}/{s}": k for n, f in per.items() for s, k in f["restarts"].items()},
            "student_error_first_lesson": {n: f["student_error_first_lesson"] for n, f in per.items()},
            "student_error_last": {n: f["student_error_last"] for n, f in per.items()},
            "student_error_taught_reference": {n: f["student_error_taught_reference"] for n, f in per.items()},
            "student_error_program_reference": {n: f["student_error_program_reference"] for n, f in per.items()},
            "person_taught_error": {n: f["person_taught_error"] for n, f in per.items()},
            "recordings_all_open": all(f["recordings_all_open"] for f in per.values()),
            "profiles": per}
