"""Debian's chromium, headless, driven by Playwright: for the page's tests and benchmark, which see the
page as a person does. Playwright's own browser download is never used (this machine has no internet):
the Debian package is, at $DOGGED_CHROMIUM or /usr/bin/chromium (`make test` installs it)."""
from __future__ import annotations

import os
from contextlib import contextmanager
from pathlib import Path

CHROMIUM = Path(os.environ.get("DOGGED_CHROMIUM", "/usr/bin/chromium"))
# a closed network: no background fetches, no QUIC, no first-run; root needs --no-sandbox
ARGS = ["--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run", "--disable-background-networking",
        "--disable-component-update", "--disable-sync", "--autoplay-policy=no-user-gesture-required"]


@contextmanager
def open_page(url: str, width: int = 1100, height: int = 1300, before: str | None = None):
    """A Playwright page at `url` in headless chromium; closed (and the browser with it) on exit.
    `before`: JavaScript run in the page before its own (a test's listener on the page's sound)."""
    if not CHROMIUM.exists():
        raise FileNotFoundError(f"no chromium at {CHROMIUM}: `sudo apt-get install chromium` (make test does, as "
                                "root), or set DOGGED_CHROMIUM")
    from playwright.sync_api import sync_playwright
    with sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path=str(CHROMIUM), headless=True, args=ARGS)
        try:
            page = browser.new_page(viewport={"width": width, "height": height})
            if before:
                page.add_init_script(before)
            page.goto(url)
            yield page
        finally:
            browser.close()
