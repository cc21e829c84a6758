"""Every number a box takes on its command line is checked as it is read: a profile with a rate of -1, a NaN
deadline or a seed of 1.5 is refused at start with the flag named, not run (issue: fail closed)."""
import importlib
import re

import pytest

from services.boxes import BOX_ROLES, parse_box_args
from services.boxes.numbers import number

REQUIRED = {"recorder": ["--out", "x"],  # the flags a box cannot start without
            "chain": ["--upper", "u", "--lower", "l", "--consumer-spaces", "robot/aibo/spaces"]}


def numeric_flags():
    for box in sorted(BOX_ROLES):
        for action in importlib.import_module(f"services.boxes.{box}").arg_parser()._actions:
            if action.option_strings and action.type is not None:
                yield box, action


def test_no_box_reads_a_number_unchecked():
    raw = [f"{box} {a.option_strings[0]}" for box, a in numeric_flags() if a.type in (int, float)]
    assert raw == [], raw
    assert len([1 for _, a in numeric_flags() if getattr(a.type, "checked", False)]) >= 20


@pytest.mark.parametrize("box,action", [(b, a) for b, a in numeric_flags() if getattr(a.type, "checked", False)],
                         ids=lambda v: v if isinstance(v, str) else v.option_strings[0])
@pytest.mark.parametrize("bad", ["nan", "inf", "-inf", "1e999", "many", "-1", "-1e12"])
def test_a_number_not_finite_or_out_of_range_is_refused_naming_its_flag(box, action, bad):
    """(no box takes a negative number: rates, seconds, seeds, counts and shares are all >= 0)"""
    flag = action.option_strings[0]
    with pytest.raises(ValueError, match=re.escape(flag)):
        parse_box_args(box, REQUIRED.get(box, []) + [flag, bad])
    assert parse_box_args(box, REQUIRED.get(box, [])).__dict__[action.dest] == action.default  # default still ok


def test_number_bounds():
    at_most_one = number(at_least=0.0, at_most=1.0)
    assert at_most_one("0") == 0.0 and at_most_one("1") == 1.0
    for bad in ("-0.001", "1.001", "nan"):
        with pytest.raises(Exception, match="expected a finite number, >= 0, <= 1"):
            at_most_one(bad)
    positive = number(above=0.0)
    with pytest.raises(Exception, match="> 0"):
        positive("0")
    assert number(int, at_least=0)("7") == 7
    with pytest.raises(Exception, match="expected an integer"):
        number(int, at_least=0)("7.5")
