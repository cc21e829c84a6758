# The two commands of the README, and the fast tier. Each sets itself up: a .venv with the project and its tools.
PYTHON ?= $(shell command -v python3.11 || command -v python3)
VENV := .venv
STAMP := $(VENV)/.installed
# the page's tests drive this chromium; root installs Debian's here, a user without it has those tests skipped
export DOGGED_CHROMIUM ?= /usr/bin/chromium
USER_ID ?= $(shell id -u)

.PHONY: demo test check chromium bench clean lerobot-check

$(STAMP): pyproject.toml
	@$(PYTHON) -c 'import sys; sys.exit(0 if sys.version_info[:2] == (3, 11) else "dogged needs Python 3.11 (pybullet 3.2.7 ships wheels for 3.11 only); set PYTHON=/path/to/python3.11")'
	$(PYTHON) -m venv $(VENV)
	$(VENV)/bin/pip install --quiet --upgrade pip
	$(VENV)/bin/pip install --quiet -e '.[test]'
	touch $(STAMP)

demo: $(STAMP)
	$(VENV)/bin/dogged demo

# the page's tests drive Debian's chromium (Playwright, with no browser download of its own): root installs
# it at /usr/bin/chromium; anyone else (or another DOGGED_CHROMIUM) without it runs the rest, and pytest
# lists the page's tests as skipped with the command that installs it
chromium:
	@if [ -e "$(DOGGED_CHROMIUM)" ]; then :; \
	elif [ "$(USER_ID)" = 0 ] && [ "$(DOGGED_CHROMIUM)" = /usr/bin/chromium ]; then \
		apt-get install -y -qq --no-install-recommends chromium >/dev/null 2>&1 || \
		(apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends chromium >/dev/null); \
	else echo "no chromium at $(DOGGED_CHROMIUM): the page's tests will be skipped; to run them: sudo apt-get install chromium" >&2; fi

# every test in three tiers: the live ones (processes that mostly wait on real time, judged on it) at the machine's
# priority, and beside them at the lowest, make check's fast tier then the slow one (CPU alone: no process, no
# session; 4 minutes of a 2-core CI's 25, run one after the other), which take what the live ones leave of
# the cores and never what they need. Their report follows the live one's; all must pass
# tiers, and on CPU 0 alone where there are more: the supervisor runs a profile's tick path on the upper CPUs
# (services/placement.py), which a tier beside it then never wakes on (a fresh clone's CI on a 2-core machine half
# as fast as the last failed the fuzz suite's rate, 24 of 30 Hz, with the tiers on every CPU)
BESIDE_LOG := .beside-tiers.log
BESIDE := sh rigs/beside.sh $(shell [ "$$(nproc)" -gt 1 ] && command -v taskset >/dev/null && echo taskset -c 0)
test: $(STAMP) chromium
	$(VENV)/bin/ruff check .
	@($(BESIDE) $(VENV)/bin/pytest -q -rs -p no:cacheprovider --fast-tier; fast=$$?; \
	$(BESIDE) $(VENV)/bin/pytest -q -rs -p no:cacheprovider --durations=10 --slow-tier && exit $$fast) \
	> $(BESIDE_LOG) 2>&1 & beside=$$!; \
	$(VENV)/bin/pytest -q -rs --durations=30 --live-tier; live=$$?; \
	wait $$beside; tiers=$$?; echo "--- the fast and slow tiers, beside them:"; cat $(BESIDE_LOG); \
	[ $$live = 0 ] && [ $$tiers = 0 ]

# the fast tier, after each change: ruff and every test that starts no process and takes a second at most
# (tests/fast_tier.py: a test of the tier that starts a process, or uses over 5 s of CPU, fails); under a minute
check: $(STAMP)
	$(VENV)/bin/ruff check .
	$(VENV)/bin/pytest -q --fast-tier --durations=5

# The exported datasets read by LeRobot's own reader (tests/test_export_live.py; make test skips that part):
# lerobot-dataset imports torch and torchvision (about 6 GB here) and decodes video with torchcodec, which
# needs FFmpeg's libraries (Debian's ffmpeg, installed as root); so they get a venv of their own
LEROBOT_VENV := .venv-lerobot
lerobot-check: $(STAMP)
	@command -v ffmpeg >/dev/null || [ "$(USER_ID)" != 0 ] || (apt-get update -qq && \
		DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends ffmpeg >/dev/null)
	test -x $(LEROBOT_VENV)/bin/python || $(PYTHON) -m venv $(LEROBOT_VENV)
	$(LEROBOT_VENV)/bin/pip install --quiet lerobot-dataset==0.4.4 torch==2.14.1 torchvision==0.29.1 torchcodec==0.17.0
	DOGGED_LEROBOT_PYTHON=$(abspath $(LEROBOT_VENV))/bin/python $(VENV)/bin/pytest -q -rs tests/test_export_live.py

bench: $(STAMP)
	for b in benchmarks/*.py; do $(VENV)/bin/python $$b --quick || exit 1; done

clean:
	rm -rf $(VENV) $(LEROBOT_VENV) runs deploy/runs .pytest_cache
