"""Debian's chromium, headless, driven by Playwright: for the page's tests and benchmark, which see the
page as a person does. Playwright's own browser download is never used (this machine has no internet):
the Debian package is, at $DOGGED_CHROMIUM or /usr/bin/chromium (`make test` installs it as root; without
it the page's tests are skipped, saying why)."""
from __future__ import annotations

import os
from contextlib import contextmanager
from pathlib import Path

CHROMIUM = Path(os.environ.get("DOGGED_CHROMIUM", "/usr/bin/chromium"))
# a closed network: no background fetches, no QUIC, no first-run; root needs --no-sandbox
ARGS = ["--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run", "--disable-background-networking",
        "--disable-component-update", "--disable-sync", "--autoplay-policy=no-user-gesture-required"]


def missing_chromium(path: Path = CHROMIUM) -> str | None:
    """Why the page cannot be opened in chromium at `path` (what to install), or None when it can."""
    if path.exists():
        return None
    return (f"no chromium at {path}: the page's tests need Debian's chromium: `sudo apt-get install chromium` "
            "(make test does, as root), or set DOGGED_CHROMIUM to one")


@contextmanager
def open_page(url: str, width: int = 1100, height: int = 1300, before: str | None = None):
    """A Playwright page at `url` in headless chromium; closed (and the browser with it) on exit.
    `before`: JavaScript run in the page before its own (a test's listener on the page's sound)."""
    missing = missing_chromium()
    if missing:
        raise FileNotFoundError(missing)
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
