"""The scripted day: what two teachers, a person at the page, the network, the operating system, the disk
and a stranger do to a running profile, and when (seconds from the day's start). Pure data, so it can be
read and tested without a profile; benchmarks/soak.py carries it out.

Lessons come in a cycle of four spells: the teacher here teaches, the student is alone, the teacher on
the other host teaches (every other time its link is cut a while and restored), the student is alone.
The day ends on a spell alone, with the learner the profile wires (the swaps go through the others and
back before it): before the day's last lesson it waits for a swap still under way (`hold`), so that the last
spell alone is the wired learner's however long its swap took. A person drives from the page now and then,
at the start of a spell alone; the student's error is measured only while it is alone and nobody drives
(`alone` events).
"""
from __future__ import annotations

import random
from dataclasses import dataclass

# kinds of events; `alone` opens (True) or closes (False) a span in which the student's error counts
# `hold`: the day's clock stops here until no swap is under way or due (Driver.run)
KINDS = ("teach", "alone", "cut", "heal", "drive", "swap", "kill", "stranger", "fill", "free", "arena", "hold")
DISRUPTIVE = ("swap", "kill", "stranger", "fill")  # kept apart from each other (see `spaced`)
SETTLE_S = 1.0  # after a teacher stops or a person lets go, before the student counts as alone
FIRST_KILLED = ("router", "recorder")  # killed first, so even a short day kills both


@dataclass(frozen=True)
class Pace:
    """How long the day is and how often each thing happens (seconds)."""
    length_s: float
    lesson_s: float        # a lesson, and each spell alone after one
    swap_s: float          # `dogged swap` of the learner
    kill_s: float          # a SIGKILL of a service
    stranger_s: float      # a stranger's burst
    drive_every_s: float   # a person drives at the first spell alone of every such stretch...
    drive_s: float         # ...for this long
    cut_s: float           # the other host's link cut (every other remote lesson)
    fill_at_s: float       # the recordings' disk filled at this time...
    fill_s: float          # ...for this long, then freed
    sample_s: float        # every figure sampled this often
    warmup_s: float        # a process's first stretch, left out of its growth
    spacing_s: float       # disruptive events at least this far apart


def pace(hours: float, quick: bool) -> Pace:
    """The hour's day for `hours` (each profile's): shorter than an hour, every time scales down with it (the
    same events, closer together); longer, the hour's pace goes on. --quick: a minute that still holds one
    of each (one drive: the person's 3 s are 5 % of the day, as the hour's 30 s every 16 min are 3 %; with two
    drives, 10 %, the person's pairs, which the wired GP learns slowest, held CI's quick mirroring day 90 s
    for its last swap)."""
    if quick:
        return Pace(length_s=60.0, lesson_s=7.5, swap_s=10.0, kill_s=15.0, stranger_s=30.0, drive_every_s=60.0,
                    drive_s=3.0, cut_s=2.5, fill_at_s=24.0, fill_s=8.0, sample_s=10.0, warmup_s=12.0, spacing_s=2.0)
    if hours <= 0:
        raise ValueError(f"--hours must be > 0, got {hours}")
    length, k = hours * 3600.0, min(hours, 1.0)
    return Pace(length_s=length, lesson_s=120.0 * k, swap_s=600.0 * k, kill_s=300.0 * k, stranger_s=600.0 * k,
                drive_every_s=960.0 * k, drive_s=30.0 * k, cut_s=30.0 * k, fill_at_s=0.4 * length, fill_s=60.0 * k,
                sample_s=60.0 * k, warmup_s=600.0 * k, spacing_s=30.0 * k)


@dataclass(frozen=True, order=True)
class Event:
    at: float
    kind: str
    arg: tuple = ()


def swap_specs(others: list[str], wired: str, swaps: int) -> list[str]:
    """The learners swapped in, in turn: every other one and back to the wired one, again and again; the last
    round as many of the others as fit, then back (a lone swap left over is not made)."""
    cycle = others + [wired]
    rounds, left = divmod(swaps, len(cycle))
    return cycle * rounds + (others[:left - 1] + [wired] if left >= 2 else [])


def kill_order(services: list[str], kills: int, rng: random.Random) -> list[str]:
    """The services killed, in turn: the router and the recorder first, then every other in a shuffled
    order, then all of them shuffled again and again (each killed as often as any other)."""
    first = [s for s in FIRST_KILLED if s in services]
    order = first + rng.sample([s for s in services if s not in first], len(services) - len(first))
    while len(order) < kills:
        order += rng.sample(services, len(services))
    return order[:kills]


def lessons(p: Pace, teachers: tuple[str, str]) -> list[Event]:
    """The cycle of spells, ending on one alone; with its cuts, drives and arena resets."""
    spells = int(p.length_s // p.lesson_s) // 2 * 2
    if spells < 2:
        raise ValueError(f"a day of {p.length_s:g} s holds no lesson of {p.lesson_s:g} s and a spell alone after it")
    events, remote_lessons, next_drive = [], 0, 0.0
    for i in range(spells):
        start, end = i * p.lesson_s, (i + 1) * p.lesson_s
        # (the last spell alone is in the arena of the first, so that their errors compare)
        events.append(Event(start, "arena", (1 if i == spells - 1 else i,)))
        if i % 2 == 0:  # a lesson: here, then on the other host, in turn
            teacher = teachers[(i // 2) % 2]
            events += [Event(start, "teach", (teacher, True)), Event(end, "teach", (teacher, False))]
            if (i // 2) % 2 == 1:
                if remote_lessons % 2 == 0:
                    cut = start + p.lesson_s / 3
                    events += [Event(cut, "cut"), Event(cut + min(p.cut_s, p.lesson_s / 2), "heal")]
                remote_lessons += 1
            continue
        alone_from = start + SETTLE_S
        if start >= next_drive and i > 1:  # not the first spell alone: it measures the first lesson
            events.append(Event(start, "drive", (p.drive_s,)))
            alone_from += p.drive_s
            next_drive = (start // p.drive_every_s + 1) * p.drive_every_s
        events += [Event(alone_from, "alone", (True,)), Event(end, "alone", (False,))]
    return events


def spaced(events: list[Event], gap: float) -> list[Event]:
    """The disruptive events moved later, each at least `gap` after the one before it."""
    out, last = [], -float("inf")
    for e in sorted(events):
        if e.kind in DISRUPTIVE:
            if e.at < last + gap:
                e = Event(last + gap, e.kind, e.arg)
            last = e.at
        out.append(e)
    return sorted(out)


def day(p: Pace, teachers: tuple[str, str], services: list[str], others: list[str], wired: str,
        seed: int = 0) -> list[Event]:
    """Every event of the day, in order. `teachers`: (here, on the other host); `services`: those a SIGKILL
    may hit ("learner": whichever serves then); `others`: learners to swap through before `wired`."""
    rng = random.Random(seed)
    events = lessons(p, teachers)
    last_alone = max(e.at for e in events if e.kind == "alone" and e.arg == (True,))
    quiet_from = last_alone - 2 * p.lesson_s  # the last spell alone is the day's measure: left in peace
    swap_times = [k * p.swap_s for k in range(1, int(p.length_s // p.swap_s) + 1) if k * p.swap_s <= quiet_from]
    events += [Event(t, "swap", (spec,)) for t, spec in zip(swap_times, swap_specs(others, wired, len(swap_times)))]
    kill_times = [(k + 0.5) * p.kill_s for k in range(int(p.length_s // p.kill_s) + 1)
                  if (k + 0.5) * p.kill_s <= quiet_from]
    events += [Event(t, "kill", (s,)) for t, s in zip(kill_times, kill_order(services, len(kill_times), rng))]
    events += [Event((k + 0.7) * p.stranger_s, "stranger") for k in range(int(p.length_s // p.stranger_s) + 1)
               if (k + 0.7) * p.stranger_s <= quiet_from]
    if p.fill_at_s + p.fill_s <= quiet_from:
        events += [Event(p.fill_at_s, "fill"), Event(p.fill_at_s + p.fill_s, "free")]
    events = spaced(events, p.spacing_s)
    free = next((e for e in events if e.kind == "free"), None)
    fill = next((e for e in events if e.kind == "fill"), None)
    if fill and free and free.at < fill.at + p.fill_s:  # the fill moved: the disk stays full as long
        events = sorted([e for e in events if e is not free] + [Event(fill.at + p.fill_s, "free")])
    # the last lesson waits for the last swap (the wired learner's, with the whole day's history to learn: 823 s
    # for 43,897 pairs in an hour at dafb009, past its 600 s slot, so the gp before it was judged at the end).
    # At the lesson's start, after the spell before it closed and the arena was set ("alone", "arena" < "hold")
    last_lesson = max(e.at for e in events if e.kind == "teach" and e.arg[1])
    return sorted(events + [Event(last_lesson, "hold")])
