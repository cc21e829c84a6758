"""deploy/ballseek.toml with its page (`dogged ui`), brought up for the page's tests and benchmark: the
profile file itself, its page on a given port, its learner's state and the logs in the run's folder."""
from __future__ import annotations

from pathlib import Path

from services.demo.live import REPO, LiveRun

PROFILE = REPO / "deploy" / "ballseek.toml"
PAGE_ADDRESS = '"127.0.0.1:8080"'
STATE_DIR = '"runs/ballseek/state"'


def start_ballseek_with_page(run_dir: Path, endpoint: str, port: int) -> LiveRun:
    text = PROFILE.read_text()
    for part in (PAGE_ADDRESS, STATE_DIR, "[profile]\n"):
        if part not in text:
            raise ValueError(f"{PROFILE} no longer holds {part.strip()}: update services/demo/page.py")
    text = (text.replace(PAGE_ADDRESS, f'"127.0.0.1:{port}"').replace(STATE_DIR, f'"{run_dir / "state"}"')
            .replace("[profile]\n", f'[profile]\nlog_dir = "{run_dir / "logs"}"\n', 1))
    run_dir.mkdir(parents=True, exist_ok=True)
    (run_dir / "ballseek.toml").write_text(text)
    run = LiveRun(run_dir / "ballseek.toml", run_dir, endpoint)
    run.wait_ready()
    return run
