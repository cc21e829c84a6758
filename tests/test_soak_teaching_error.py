"""What the page person taught, judged as the soak's student is (rigs/soak/taught.teaching_error): the program on
each pair's input against the pair's output, over the pairs of the sources asked and teaching every judged output."""
from types import SimpleNamespace

import numpy as np
import pytest

from rigs.soak.taught import teaching_error
from rigs.soak.watch import Judge


def program(x):
    return (None, 1.0) if x[0] < 0 else (np.array([x[0], -x[0]]), 1.0)


JUDGE = Judge(program, [0, 1], np.array([1.0, 1.0]))


def run(x, y, mask, sources):
    return SimpleNamespace(pair_x=np.array(x, dtype=float), pair_y=np.array(y, dtype=float),
                           pair_mask=np.array(mask, dtype=float), pair_sources=np.array(sources))


def test_the_persons_pairs_are_judged_against_the_program_and_the_programs_left_out():
    r = run([[0.5], [0.2], [0.3]], [[0.5, -0.5], [0.2, -0.1], [0.0, 0.0]], [[1, 1]] * 3,
            ["teacher/seeker", "teacher/person", "teacher/person"])
    error, pairs = teaching_error(r, JUDGE, {"teacher/person"})
    # RMS over both outputs: (0, 0.1) -> 0.1/sqrt 2; (0.3, 0.3) -> 0.3
    assert pairs == 2 and error == pytest.approx((0.1 / np.sqrt(2) + 0.3) / 2)


def test_a_pair_not_teaching_every_judged_output_nor_one_the_program_has_no_answer_for_is_not_judged():
    r = run([[0.5], [-1.0]], [[9.0, 0.0], [0.0, 0.0]], [[1, 0], [1, 1]], ["teacher/person", "teacher/person"])
    assert teaching_error(r, JUDGE, {"teacher/person"}) == (None, 0)


def test_nobody_else_taught_nothing_judged():
    r = run(np.zeros((0, 1)), np.zeros((0, 2)), np.zeros((0, 2)), np.zeros(0, dtype=str))
    assert teaching_error(r, JUDGE, set()) == (None, 0)
