"""make check's tier (tests/fast_tier.py) on small test files run by an inner pytest in this process: it
leaves the live and slow tests out, and a test put in it by mistake fails, saying which mark to add."""
import pytest

from tests import fast_tier

pytest_plugins = ["pytester"]

TIER = ("-p", "tests.fast_tier", fast_tier.FLAG)
DOOR_CALLS = {  # each door, called as a test would; the tier refuses it before anything starts
    "subprocess": "import subprocess; subprocess.run(['true'])",
    "os.system": "import os; os.system('true')",
    "multiprocessing": "import multiprocessing; multiprocessing.get_context('spawn').Process(target=print).start()",
    "zenoh": "import zenoh; zenoh.open(zenoh.Config())",
}


@pytest.mark.parametrize("door", DOOR_CALLS)
def test_a_test_of_the_tier_that_starts_a_process_fails_and_says_to_mark_it_live(pytester, door):
    pytester.makepyfile(f"def test_it():\n    {DOOR_CALLS[door]}\n")
    result = pytester.runpytest_inprocess(*TIER)
    result.assert_outcomes(failed=1)
    result.stdout.fnmatch_lines(["*test_it is in make check's fast tier but started a process*mark it live*"])


def test_one_that_catches_the_refusal_fails_too(pytester):
    pytester.makepyfile("""
        import contextlib, subprocess
        def test_it():
            with contextlib.suppress(Exception):
                subprocess.run(["true"])
    """)
    result = pytester.runpytest_inprocess(*TIER)
    result.assert_outcomes(failed=1)
    result.stdout.fnmatch_lines(["*started a process or a Zenoh session (subprocess.Popen*"])


def test_one_over_the_cpu_ceiling_fails_and_says_to_mark_it_slow_one_that_waits_does_not(pytester, monkeypatch):
    monkeypatch.setattr(fast_tier, "CEILING_S", 0.05)
    pytester.makepyfile("""
        import time
        def test_waits():
            time.sleep(0.2)
        def test_computes():
            started = time.process_time()
            while time.process_time() - started < 0.1:
                pass
    """)
    result = pytester.runpytest_inprocess(*TIER)
    result.assert_outcomes(passed=1, failed=1)
    result.stdout.fnmatch_lines(["*test_computes is in make check's fast tier but used 0.1 s of CPU*mark it slow*"])


def test_live_and_slow_tests_and_those_asking_for_a_router_are_left_out_of_the_tier_and_are_the_rest(pytester):
    pytester.makeconftest("import pytest\n@pytest.fixture\ndef router():\n    yield 'tcp/127.0.0.1:1'\n")
    pytester.makepyfile("""
        import pytest
        @pytest.mark.live
        def test_live(): pass
        @pytest.mark.slow
        def test_slow(): pass
        def test_with_a_router(router): pass
        def test_fast(): pass
    """)
    tier = pytester.runpytest_inprocess(*TIER, "-v")
    tier.assert_outcomes(passed=1, deselected=3)
    tier.stdout.fnmatch_lines(["*::test_fast PASSED*"])
    rest = pytester.runpytest_inprocess("-p", "tests.fast_tier", fast_tier.REST, "-v")
    rest.assert_outcomes(passed=3, deselected=1)
    rest.stdout.fnmatch_lines(["*::test_live PASSED*", "*::test_slow PASSED*", "*::test_with_a_router PASSED*"])
    live = pytester.runpytest_inprocess("-p", "tests.fast_tier", fast_tier.LIVE, "-v")
    live.assert_outcomes(passed=2, deselected=2)
    live.stdout.fnmatch_lines(["*::test_live PASSED*", "*::test_with_a_router PASSED*"])
    slow = pytester.runpytest_inprocess("-p", "tests.fast_tier", fast_tier.SLOW, "-v")
    slow.assert_outcomes(passed=1, deselected=3)
    slow.stdout.fnmatch_lines(["*::test_slow PASSED*"])
    everything = pytester.runpytest_inprocess("-p", "tests.fast_tier")
    everything.assert_outcomes(passed=4)
    both = pytester.runpytest_inprocess(*TIER, fast_tier.REST)
    both.stderr.fnmatch_lines(["*--fast-tier and --rest-of-tiers: the tiers do not overlap, ask for one*"])


def test_the_slow_tier_fails_a_test_that_starts_a_process_but_not_one_that_computes(pytester, monkeypatch):
    """The slow tier runs beside the live tests at the lowest priority: a process started there would be starved,
    so it fails, saying to mark it live; CPU is what the tier is for."""
    monkeypatch.setattr(fast_tier, "CEILING_S", 0.05)
    pytester.makepyfile(f"""
        import time, pytest
        @pytest.mark.slow
        def test_starts():
            {DOOR_CALLS["subprocess"]}
        @pytest.mark.slow
        def test_computes():
            started = time.process_time()
            while time.process_time() - started < 0.1:
                pass
    """)
    result = pytester.runpytest_inprocess("-p", "tests.fast_tier", fast_tier.SLOW)
    result.assert_outcomes(passed=1, failed=1)
    result.stdout.fnmatch_lines(["*test_starts is in the slow tier*but started a process*mark it live*"])


def test_the_tier_gives_every_door_back_when_it_ends(pytester):
    import os
    import subprocess

    import zenoh
    before = [getattr(owner, name) for owner, name, _ in fast_tier.DOORS if hasattr(owner, name)]
    pytester.makepyfile("def test_it(): pass\n")
    pytester.runpytest_inprocess(*TIER).assert_outcomes(passed=1)
    assert [getattr(owner, name) for owner, name, _ in fast_tier.DOORS if hasattr(owner, name)] == before
    assert {subprocess.Popen.__init__, os.fork, zenoh.open} <= set(before)
