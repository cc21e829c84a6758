"""The soak's student figures (rigs/soak/figures.py): the error per span alone, and the last span told apart
into the ticks the learner's answer drove and those held without it."""
import pytest

from rigs.soak.figures import alone_errors, last_span_split

# (command arrival, span alone, error, driven by the learner's answer)
ERRORS = [(1.0, 0, 0.1, True), (2.0, 0, 0.3, True), (5.0, 1, 0.01, True), (5.1, 1, 0.03, True),
          (5.2, 1, 0.5, False)]


def test_each_span_alone_is_the_mean_of_every_judged_tick_held_or_not():
    assert alone_errors(ERRORS) == pytest.approx([0.2, 0.18])


def test_the_last_span_tells_the_learners_ticks_from_those_held_without_it():
    assert last_span_split(ERRORS) == {"answered": 2, "held": 1, "error_answered": 0.02, "error_held": 0.5}


def test_a_last_span_the_learner_never_answered_has_no_error_of_its_own():
    split = last_span_split([(1.0, 0, 0.1, True), (3.0, 2, 0.4, False)])
    assert split == {"answered": 0, "held": 1, "error_answered": None, "error_held": 0.4}


def test_no_span_alone_gives_no_figures():
    assert last_span_split([]) == {"answered": 0, "held": 0, "error_answered": None, "error_held": None}
