"""Tick latency of the whole loop (platform -> learner -> arbitrator -> platform) over Zenoh.

Real processes on a real router on loopback: point platform, a teacher switched off, an LWPR
learner, the arbitrator. The floor is a raw UDP round trip between two processes, measured in
the same run, and a Zenoh ping-pong between two Python processes that hand samples to their main
threads as the services do (benchmarks/lib/zenoh_echo.py): a tick crosses three such hops, so
1.5 of its round trips, paced as ticks come (100 Hz, 1 kHz: both processes idle and wake in
between), is the tick's floor in Python over Zenoh. Everything is measured twice: as
deployed by default, then in low-latency mode (a PM QoS request keeping CPUs out of deep idle,
`low_latency = true` in a profile); keys of the second carry `_low_latency`; the 100 Hz loop is
also measured with a recorder writing every sample (`_recorded`: every profile runs one), and split
into hops as an observer on the bus sees them (`hop_us_*`, benchmarks/lib/hops.py).
Beside them the null tick (benchmarks/lib/null_tick.py): the loop's processes and hops with no work in
them, at 100 Hz and 1 kHz (`tick_null_ms[_1khz]`, `tick_null_over_floor[_1khz]`, `tick_p50_over_null[_1khz]`):
what the loop's shape costs beyond the floor, and what the services' own work and waits cost beyond that.

Then what users run (issue 34): each profile of deploy/ as it is, with its wired learner, while a teacher
teaches and while the student drives (`<profile>_tick_*`, beside `<profile>_tick_floor_ms`, the Zenoh round
trip at its rate times half its hops; benchmarks/lib/profile_ticks.py), the deploy profiles secured by this
user's own identities and with the tick path on CPUs of its own, as they run by default (the platform's own view
too: `<profile>_platform_p50_ms`, `_p99_ms`), and mirroring again with security = "off" (`mirroring_off_*`;
`security_tick_p50_ratio[_teaching]`: secured over unsecured, same run) and with tick_cpus = "off"
(`mirroring_unplaced_*`; `placement_<figure>_ratio[_teaching]`: placed over unplaced, same run), and each
learner's cost per call at the profiles' shapes (`learner_*`, benchmarks/lib/learner_costs.py). Prints tables;
the last line is one JSON object of the figures.
"""
from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # the repository: rigs.*, benchmarks.*
import services  # noqa: E402,F401  (first: one BLAS thread per process, see services/__init__.py)

import argparse
import json
import tempfile
import time

import numpy as np

from benchmarks.lib.hops import DESCRIBED, HOPS, HopObserver  # noqa: E402
from benchmarks.lib import learner_costs, null_tick, profile_ticks, zenoh_echo  # noqa: E402
from benchmarks.lib.udp_echo import round_trips  # noqa: E402
from rigs.harness import Probe, dogged, free_port, stop  # noqa: E402
from services.realtime import hold_low_latency, release_low_latency  # noqa: E402


def udp_floor(count: int) -> np.ndarray:
    port = free_port()
    proc = dogged_python("benchmarks/lib/udp_echo.py", str(port), "60")
    time.sleep(0.5)
    try:
        round_trips(port, 200, b"x" * 96)  # warm up
        return round_trips(port, count, b"x" * 96)
    finally:
        stop(proc)


def zenoh_floor(router: str, quick: bool) -> dict[float, np.ndarray]:
    """Round trips (ms) back to back (rate 0) and paced as ticks come, at 1 kHz and 100 Hz, and at each
    profile's rate (5 s of it, quick; 20 s)."""
    proc = dogged_python("benchmarks/lib/zenoh_echo.py", router, "600")
    counts = {0.0: 2000, 1000.0: 2000, 100.0: 300} if quick else {0.0: 10000, 1000.0: 10000, 100.0: 2000}
    paced = {rate: int(rate * (5 if quick else 20)) for rate in profile_ticks.rates()}
    try:
        out = {rate: zenoh_echo.round_trips(router, n, rate_hz=rate) * 1e3 for rate, n in counts.items()}
        # at a profile's slow pace a second's round trips warm up, not 200 (13 s at 15 Hz)
        return out | {rate: zenoh_echo.round_trips(router, n, rate_hz=rate, warm_up=int(rate)) * 1e3
                      for rate, n in paced.items()}
    finally:
        stop(proc)


def dogged_python(*args: str):
    import subprocess
    from rigs.harness import REPO
    return subprocess.Popen([sys.executable, *args], cwd=REPO, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)


def run_platform(router: str, rate: float, ticks: int, work: Path, env: dict | None = None) -> tuple[np.ndarray, dict]:
    lat, summary = work / f"lat-{rate:g}.npy", work / f"sum-{rate:g}.json"
    proc = dogged("run", "platform", "--param", "dims=2", "--rate", str(rate), "--max-ticks", str(ticks),
                  "--latency-log", str(lat), "--summary", str(summary), "--connect", router,
                  log=work / f"platform-{rate:g}.log", env=env)
    proc.wait(timeout=ticks / rate + 60)
    return np.load(lat) * 1e3, json.loads(summary.read_text())


def measure(router: str, work: Path, quick: bool, label: str, observer: HopObserver) -> tuple[list, dict]:
    rows, figures = [], {}
    for rate, seconds in ((100, 10 if quick else 30), (1000, 5 if quick else 20)):
        ms, counts = run_platform(router, rate, int(rate * seconds), work)
        ms = ms[len(ms) // 20:]  # the first 5% include connection set-up
        rows.append((f"{label} {rate} Hz", len(ms), np.percentile(ms, 50), np.percentile(ms, 99), counts["unanswered"]))
    observer.start()  # the hops in a run of their own: the observer is one more subscriber on the tick path
    ms, counts = run_platform(router, 100, 100 * (10 if quick else 30), work)
    ms = ms[len(ms) // 20:]
    figures |= {f"hop_us_{hop}": us for hop, us in observer.hops_us(ms).items()}
    rows.append((f"{label} observed 100 Hz", len(ms), np.percentile(ms, 50), np.percentile(ms, 99),
                 counts["unanswered"]))
    figures["tick_p50_ms"], figures["tick_p99_ms"] = round(rows[0][2], 3), round(rows[0][3], 3)
    figures["tick_p50_ms_1khz"], figures["tick_p99_ms_1khz"] = round(rows[1][2], 3), round(rows[1][3], 3)
    held = 0
    for rate in (1000, 1500, 2000, 3000, 4000, 6000):
        ms, counts = run_platform(router, rate, int(rate * (2 if quick else 5)), work)
        rows.append((f"{label} ramp {rate} Hz", len(ms), np.percentile(ms, 50), np.percentile(ms, 99),
                     counts["unanswered"]))
        if counts["unanswered"] or counts["ticks"] < rate * (2 if quick else 5) * 0.999:
            break
        held = rate
    figures["max_rate_hz"] = held
    return rows, figures


def recorded_row(router: str, work: Path, quick: bool) -> tuple:
    """The 100 Hz loop again with a recorder writing every sample (as every profile runs one)."""
    recorder = dogged("run", "recorder", "--connect", router, "--out", str(work / "recording"),
                      log=work / "recorder.log")
    try:
        time.sleep(2)  # up and subscribed
        ms, counts = run_platform(router, 100, 100 * (10 if quick else 30), work)
    finally:
        stop(recorder)
    ms = ms[len(ms) // 20:]
    return ("recorded 100 Hz", len(ms), np.percentile(ms, 50), np.percentile(ms, 99), counts["unanswered"])


def main(quick: bool) -> dict:
    work = Path(tempfile.mkdtemp(prefix="dogged-loop-"))
    udp = udp_floor(2000 if quick else 10000) * 1e3
    router = f"tcp/127.0.0.1:{free_port()}"
    boxes = [dogged("run", "router", "--listen", router, log=work / "router.log")]
    boxes += [dogged("run", "demonstrator", "--teacher", "sine", "--connect", router, log=work / "teacher.log"),
              dogged("run", "learner", "--learner", "lwpr", "--connect", router, log=work / "learner.log"),
              dogged("run", "arbitrator", "--connect", router, log=work / "arbitrator.log")]
    probe, observer = Probe(router), HopObserver(router)
    try:
        echoed = zenoh_floor(router, quick)  # before the loop runs: alone on the bus
        nulls = {rate: null_tick.ticks(router, rate, int(rate * seconds))  # the loop's shape, no work
                 for rate, seconds in ((100.0, 10 if quick else 30), (1000.0, 5 if quick else 20))}
        time.sleep(3)  # services up, kernels compiled
        rows, figures = measure(router, work, quick, "default", observer)
        rows.append(recorded_row(router, work, quick))  # what a profile's recorder costs the tick
        figures["tick_p50_ms_recorded"], figures["tick_p99_ms_recorded"] = round(rows[-1][2], 3), round(rows[-1][3], 3)
        low = hold_low_latency()  # system-wide while this process lives: measured second
        if low:
            low_rows, low_figures = measure(router, work, quick, "low-lat", observer)
            rows += low_rows
            figures |= {f"{k}_low_latency": v for k, v in low_figures.items()}
    finally:
        probe.close()
        observer.close()
        stop(*reversed(boxes))
    release_low_latency()  # the profiles as deployed: none asks for low latency
    rtt_at = {rate: float(np.nanpercentile(rtt, 50)) for rate, rtt in echoed.items()}
    profile_rows, profile_figures = profile_ticks.measure(work, quick, rtt_at)  # alone on the machine, each
    learner_rows, learner_figures = learner_costs.measure(quick)
    figures["udp_rtt_ms"] = round(float(np.percentile(udp, 50)), 4)
    figures["udp_rtt_p99_ms"] = round(float(np.percentile(udp, 99)), 4)
    figures["tick_p50_over_udp"] = round(figures["tick_p50_ms"] / figures["udp_rtt_ms"], 1)
    floor_rows = []
    profile_rates = [(rate, f"_{rate:g}hz") for rate in profile_ticks.rates()]
    for rate, suffix in ((0.0, ""), (1000.0, "_1khz"), (100.0, "_100hz"), *profile_rates):
        rtt = echoed[rate]
        figures[f"zenoh_rtt_ms{suffix}"] = round(float(np.nanpercentile(rtt, 50)), 4)
        figures[f"zenoh_rtt_p99_ms{suffix}"] = round(float(np.nanpercentile(rtt, 99)), 4)
        floor_rows.append((f"Zenoh RTT {'back to back' if not rate else f'{rate:g} Hz'}", len(rtt),
                           figures[f"zenoh_rtt_ms{suffix}"], figures[f"zenoh_rtt_p99_ms{suffix}"],
                           int(np.isnan(rtt).sum())))
    # three hops, no work, at the tick's own pace
    figures["tick_floor_ms"] = round(1.5 * figures["zenoh_rtt_ms_100hz"], 4)
    figures["tick_floor_ms_1khz"] = round(1.5 * figures["zenoh_rtt_ms_1khz"], 4)
    figures["tick_p50_over_floor"] = round(figures["tick_p50_ms"] / figures["tick_floor_ms"], 2)
    figures["tick_p50_over_floor_1khz"] = round(figures["tick_p50_ms_1khz"] / figures["tick_floor_ms_1khz"], 2)
    for rate, suffix in ((100.0, ""), (1000.0, "_1khz")):
        null = nulls[rate]
        p50, p99 = round(float(np.nanpercentile(null, 50)), 4), round(float(np.nanpercentile(null, 99)), 4)
        figures[f"tick_null_ms{suffix}"], figures[f"tick_null_p99_ms{suffix}"] = p50, p99
        figures[f"tick_null_over_floor{suffix}"] = round(p50 / figures[f"tick_floor_ms{suffix}"], 2)
        figures[f"tick_p50_over_null{suffix}"] = round(figures[f"tick_p50_ms{suffix}"] / p50, 2)
        floor_rows.append((f"null tick {rate:g} Hz", len(null), p50, p99, int(np.isnan(null).sum())))
    print(f"{'run':<22}{'ticks':>8}{'p50 ms':>10}{'p99 ms':>10}{'lost':>7}{'p50/UDP':>10}")
    print(f"{'UDP round trip':<22}{len(udp):>8}{figures['udp_rtt_ms']:>10.3f}{figures['udp_rtt_p99_ms']:>10.3f}"
          f"{0:>7}{1.0:>10.1f}")
    for name, n, p50, p99, lost in floor_rows:
        print(f"{name:<22}{n:>8}{p50:>10.3f}{p99:>10.3f}{lost:>7}{p50 / figures['udp_rtt_ms']:>10.1f}")
    for label, suffix in (("100 Hz", ""), ("1000 Hz", "_1khz")):
        floor = figures[f"tick_floor_ms{suffix}"]
        print(f"{'floor ' + label:<22}{'':>8}{floor:>10.3f}{'':>10}{'':>7}{floor / figures['udp_rtt_ms']:>10.1f}"
              f"   (1.5 Zenoh RTTs at {label}; the tick is {figures[f'tick_p50_over_floor{suffix}']:.2f}x it, the null "
              f"tick {figures[f'tick_null_over_floor{suffix}']:.2f}x)")
    print("null tick: the loop's processes and hops (input to a learner, its proposal to an arbitrator, the command "
          "back) with no work in them (benchmarks/lib/null_tick.py)")
    for name, n, p50, p99, lost in rows:
        print(f"{name:<22}{n:>8}{p50:>10.3f}{p99:>10.3f}{lost:>7}{p50 / figures['udp_rtt_ms']:>10.1f}")
    print(f"\n{'hop (100 Hz, median)':<58}{'default us':>12}{'low-lat us':>12}")
    for hop in HOPS:
        low_us = figures.get(f"hop_us_{hop}_low_latency", float("nan"))
        print(f"{DESCRIBED[hop]:<58}{figures[f'hop_us_{hop}']:>12.1f}{low_us:>12.1f}")
    print(f"highest rate held with no tick lost: {figures['max_rate_hz']} Hz "
          f"(low-latency mode: {figures.get('max_rate_hz_low_latency', 'n/a')} Hz); logs in {work}")
    profile_ticks.print_table(profile_rows)
    learner_costs.print_table(learner_rows)
    return figures | profile_figures | learner_figures


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="a shorter run (about five minutes)")
    print(json.dumps(main(parser.parse_args().quick)))
