"""Gymnasium tasks taught by their teachers, judged closed-loop (services.experiments.gym).

    .venv/bin/python benchmarks/gym.py [--seeds 5] [--episodes 10] [--quick] [--workers 2]

For each environment (Pendulum-v1, CartPole-v1, MountainCarContinuous-v0, Acrobot-v1) and each learner
(the gym profile's wired one, then every registered learner with its defaults), over seeds: teach in
blocks up to 20, 40, 80 and 160 s (50 pairs a second), the student alone for `--episodes` episodes
after each block. Then, with the wired learner, the mixed initiative: a 10 s lesson, then the teacher
only when the robot asks. Prints the tables; the last line is one JSON object with, per environment,
`<env>_teach_s_to_90` (the first block whose median score over seeds reaches 0.9), `<env>_worst_after_90`
(the lowest score of any seed from that block on), `<env>_asked_teach_s_to_90` and
`<env>_requests_to_90` (medians over seeds), and `runaway_episodes` (the wired learner's student
episodes more than half unsure and below a random policy, after 60 s of teaching or more).
`--quick`: one seed, 5 episodes, the wired learner only.
"""
from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # the repository: benchmarks.*
import services  # noqa: E402,F401  (first: one BLAS thread per process, see services/__init__.py)

import argparse  # noqa: E402
import json  # noqa: E402
import multiprocessing  # noqa: E402
import time  # noqa: E402
from concurrent.futures import ProcessPoolExecutor  # noqa: E402

import numpy as np  # noqa: E402

from services.experiments import gym  # noqa: E402
from services.experiments.wiring import wired_learner  # noqa: E402
from services.learners import LEARNERS, make_learner  # noqa: E402
from services.platforms.gym import GymPlatform  # noqa: E402

BLOCKS = (20.0, 40.0, 80.0, 160.0)
FIRST_LESSON_S, JUDGE_EVERY_S, ASKED_MAX_S = 10.0, 5.0, 240.0
RUNAWAY_FROM_S = 60.0


def spec_name(spec: tuple[str, dict]) -> str:
    name, params = spec
    return name + "".join(f":{k}={v}" for k, v in sorted(params.items()))


def build(env: str, spec: tuple[str, dict], seed: int):
    with GymPlatform(env, seed=0) as platform:
        spaces = platform.spaces
    return make_learner(spec[0], spaces.input.dims, spaces.output.dims, seed=seed, **spec[1])


def run_blocks(env: str, spec: tuple[str, dict], seed: int, episodes: int, base: gym.Baseline) -> dict:
    started = time.perf_counter()
    rows = gym.blocks(env, build(env, spec, seed), seed, BLOCKS, episodes, base)
    return {"env": env, "learner": spec_name(spec), "seed": seed, "rows": rows,
            "seconds": time.perf_counter() - started}


def run_asked(env: str, spec: tuple[str, dict], seed: int, episodes: int, base: gym.Baseline) -> dict:
    result = gym.asked(env, build(env, spec, seed), seed, FIRST_LESSON_S, int(JUDGE_EVERY_S * gym.RATE), ASKED_MAX_S,
                       episodes, base)
    return {"env": env, "seed": seed, **result}


def short(env: str) -> str:
    return env.split("-v")[0].lower()


def blocks_table(results: list[dict], bases: dict) -> list[str]:
    keys = sorted({(r["env"], r["learner"]) for r in results}, key=lambda k: (list(gym.TASKS).index(k[0]), k[1]))
    env_w, learner_w = (max(len(k[i]) for k in keys) + 2 for i in (0, 1))
    lines = [f"{'env':<{env_w}}{'learner':<{learner_w}}{'teacher':>9}{'random':>9}  " +
             "".join(f"{f'{s:.0f} s':>16}" for s in BLOCKS) + "   (score median [worst], unsure %)"]
    for env, learner in keys:
        runs = [r for r in results if (r["env"], r["learner"]) == (env, learner)]
        cells = []
        for b in range(len(BLOCKS)):
            scores = [r["rows"][b]["score"] for r in runs]
            unsure = np.median([r["rows"][b]["unsure"] for r in runs])
            cells.append(f"{np.median(scores):5.2f} [{min(scores):5.2f}] {100 * unsure:3.0f}%")
        lines.append(f"{env:<{env_w}}{learner:<{learner_w}}{bases[env].teacher:9.1f}{bases[env].random:9.1f}  " +
                     "".join(f"{c:>16}" for c in cells))
    return lines


def headline(results: list[dict], asked: list[dict], wired: str, bases: dict) -> dict:
    figures, runaways = {}, 0
    for env in gym.TASKS:
        runs = [r for r in results if r["env"] == env and r["learner"] == wired]
        medians = [np.median([r["rows"][b]["score"] for r in runs]) for b in range(len(BLOCKS))]
        reached = next((b for b, m in enumerate(medians) if m >= 0.9), None)
        figures[f"{short(env)}_teach_s_to_90"] = BLOCKS[reached] if reached is not None else None
        figures[f"{short(env)}_worst_after_90"] = round(min(r["rows"][b]["score"] for r in runs
                                                            for b in range(reached, len(BLOCKS))), 3) \
            if reached is not None else None
        runaways += sum(row["runaways"] for r in runs for row in r["rows"] if row["taught_s"] >= RUNAWAY_FROM_S)
        mine = [a for a in asked if a["env"] == env]
        if mine:
            done = [a for a in mine if a["reached"]]
            figures[f"{short(env)}_asked_teach_s_to_90"] = round(float(np.median([a["taught_s"] for a in done])), 1) \
                if len(done) == len(mine) else None
            figures[f"{short(env)}_requests_to_90"] = float(np.median([a["requests"] for a in done])) \
                if len(done) == len(mine) else None
        figures[f"{short(env)}_teacher_return"] = round(bases[env].teacher, 1)
        figures[f"{short(env)}_random_return"] = round(bases[env].random, 1)
    figures["runaway_episodes"] = runaways
    return figures


def main(seeds: int, episodes: int, quick: bool, workers: int) -> dict:
    wired_spec = wired_learner("gym")
    wired = spec_name(wired_spec)
    specs = [wired_spec] + ([] if quick else [(name, {}) for name in sorted(LEARNERS)])
    bases = {env: gym.baseline(env, episodes) for env in gym.TASKS}
    jobs = [(env, spec, seed) for env in gym.TASKS for spec in specs for seed in range(seeds)]
    started = time.perf_counter()
    with ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("spawn")) as pool:
        block_futures = [pool.submit(run_blocks, env, spec, seed, episodes, bases[env]) for env, spec, seed in jobs]
        asked_futures = [pool.submit(run_asked, env, wired_spec, seed, episodes, bases[env])
                         for env in gym.TASKS for seed in range(seeds)]
        results = [f.result() for f in block_futures]
        asked = [f.result() for f in asked_futures]
    print(f"gym tasks taught in blocks, then the student alone for {episodes} episodes; {seeds} seed(s); "
          f"scores: 0 a random policy's mean return, 1 the teacher's; wired learner {wired}")
    for line in blocks_table(results, bases):
        print(line)
    print(f"\nmixed initiative, {wired}: a {FIRST_LESSON_S:.0f} s lesson, then the teacher only when asked "
          f"(judged every {JUDGE_EVERY_S:.0f} s of driving)")
    print(f"{'env':<26}{'seed':>5}{'reached 0.9':>13}{'taught s':>10}{'requests':>10}{'driven s':>10}")
    for a in asked:
        print(f"{a['env']:<26}{a['seed']:>5}{str(a['reached']):>13}{a['taught_s']:>10.1f}{a['requests']:>10}"
              f"{a['history'][-1]['driven_s'] if a['history'] else 0:>10.0f}")
    figures = headline(results, asked, wired, bases)
    figures["wired_learner"] = wired
    figures["seeds"], figures["episodes"] = seeds, episodes
    figures["seconds"] = round(time.perf_counter() - started, 1)
    print("\ntargets (wired learner): every environment at 0.9 within 120 s of teaching, worst after 0.9 >= 0.8, "
          "0 runaway episodes, fewer teaching seconds when answering requests than in blocks")
    return figures


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=5)
    parser.add_argument("--episodes", type=int, default=10)
    parser.add_argument("--workers", type=int, default=2, help="processes (default 2)")
    parser.add_argument("--quick", action="store_true", help="one seed, 5 episodes, the wired learner only")
    args = parser.parse_args()
    if args.quick:
        args.seeds, args.episodes = 1, 5
    print(json.dumps(main(args.seeds, args.episodes, args.quick, args.workers)))
