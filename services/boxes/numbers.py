"""Numbers a box takes on its command line, checked as argparse reads them, so a profile is refused at
start with the flag named: finite, and within the range the flag allows; anything else is refused."""
from __future__ import annotations

import argparse
import math


def number(kind: type = float, *, at_least: float | None = None, above: float | None = None,
           at_most: float | None = None):
    """An argparse `type`: a finite `kind` (float or int) no less than `at_least`, greater than `above` and
    no more than `at_most` (each where given)."""
    bounds = [f">= {at_least:g}" if at_least is not None else "", f"> {above:g}" if above is not None else "",
              f"<= {at_most:g}" if at_most is not None else ""]
    wanted = ("an integer" if kind is int else "a finite number") + "".join(f", {b}" for b in bounds if b)

    def read(text: str):
        try:
            value = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected {wanted}, got {text!r}") from None
        fits = (math.isfinite(value) and (at_least is None or value >= at_least)
                and (above is None or value > above) and (at_most is None or value <= at_most))
        if not fits:
            raise argparse.ArgumentTypeError(f"expected {wanted}, got {text!r}")
        return value
    read.__name__ = wanted  # what argparse calls the type in its messages
    read.checked = True  # (tests/test_box_numbers.py: every number a box takes is read by one of these)
    return read


RATE_HZ = number(at_least=0.0, at_most=1e6)   # 0: lockstep (a replay at 1000x of 1 kHz ticks at 1 MHz)
POSITIVE_HZ = number(above=0.0, at_most=1e6)
SECONDS = number(above=0.0, at_most=3600.0)
COUNT = number(int, at_least=0)
