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
    everything = pytester.runpytest_inprocess("-p", "tests.fast_tier")
    everything.assert_outcomes(passed=4)
    both = pytester.runpytest_inprocess(*TIER, fast_tier.REST)
    both.stderr.fnmatch_lines(["*--fast-tier and --rest-of-tiers are the two halves of the tests: ask for one*"])


def test_the_tier_gives_every_door_back_when_it_ends(pytester):
    import os
    import subprocess

    import zenoh
    before = [getattr(owner, name) for owner, name, _ in fast_tier.DOORS if hasattr(owner, name)]
    pytester.makepyfile("def test_it(): pass\n")
    pytester.runpytest_inprocess(*TIER).assert_outcomes(passed=1)
    assert [getattr(owner, name) for owner, name, _ in fast_tier.DOORS if hasattr(owner, name)] == before
    assert {subprocess.Popen.__init__, os.fork, zenoh.open} <= set(before)
