"""The README opens with its two commands, and they are what they say: `make demo`, and `make test`, the
whole suite (CI runs it); `make check` is the fast tier. The README fits on two screens (issue 32)."""
import re

from tests import fast_tier
from rigs.harness import REPO

README = (REPO / "README.md").read_text()
SCREENS = 2 * 60  # lines


def recipe(target: str) -> list[str]:
    """The commands of a Makefile target."""
    found = re.search(rf"^{target}:[^\n]*\n((?:\t[^\n]*\n)+)", (REPO / "Makefile").read_text(), re.M)
    assert found, f"the Makefile has no target {target}"
    return [line.strip() for line in found.group(1).splitlines()]


def test_the_readme_starts_with_exactly_the_two_commands():
    assert README.startswith("# dogged\n\n```bash\nmake demo\nmake test\n```\n")


def test_make_test_is_ruff_and_the_whole_suite_in_its_three_tiers_side_by_side_and_ci_runs_it():
    lines = recipe("test")
    assert lines[0] == "$(VENV)/bin/ruff check ."
    suite = " ".join(line.removesuffix("\\").strip() for line in lines[1:])  # (a shell line continued)
    beside = f"($(BESIDE) $(VENV)/bin/pytest -q -rs -p no:cacheprovider {fast_tier.FLAG}; fast=$$?; " \
             f"$(BESIDE) $(VENV)/bin/pytest -q -rs -p no:cacheprovider --durations=10 {fast_tier.SLOW} && exit $$fast)"
    assert suite.startswith(f"@{beside} > $(BESIDE_LOG) 2>&1 & beside=$$!;")
    # (the live tier's 30 slowest tests printed: where CI's minutes go)
    assert f"$(VENV)/bin/pytest -q -rs --durations=30 {fast_tier.LIVE}; live=$$?;" in suite
    assert suite.endswith("[ $$live = 0 ] && [ $$tiers = 0 ]")  # every tier must pass
    assert (REPO / ".ci" / "run").read_text().rstrip().endswith("\nmake test")
    # beside the live tier at the lowest priority (rigs/beside.sh, tests/test_priority.py), on CPU 0 alone where
    # there are more (the tick paths' are above)
    assert re.search(r"^BESIDE := sh rigs/beside.sh \$\(shell .*taskset -c 0\)$", (REPO / "Makefile").read_text(),
                     re.M)


def test_make_demo_runs_the_demo():
    assert recipe("demo") == ["$(VENV)/bin/dogged demo"]


def test_make_check_is_ruff_and_the_fast_tier():
    assert recipe("check") == ["$(VENV)/bin/ruff check .", f"$(VENV)/bin/pytest -q {fast_tier.FLAG} --durations=5"]


def test_the_readme_fits_on_two_screens():
    assert len(README.splitlines()) <= SCREENS, "move the detail to a page of docs/ and link it"
