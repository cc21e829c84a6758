"""A recorded run written without a bus, as the recorder writes one: a point platform's inputs, the live learner
`l`'s proposals (how many pairs it had learned), the commands and the training pairs, in a real MCAP file."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from bus_schema import Command, Input, Proposal, TrainingPair, encode
from services.platforms.point import PointPlatform
from services.recording.writer import RunWriter


def write_point_run(folder: Path, point: PointPlatform, ticks: int, lesson, backlog=lambda tick: 0) -> Path:
    """`ticks` ticks at 30 Hz; `lesson(tick, x)` gives the teacher's (y, mask or None), or None where the student
    drives (a dumb one: zeros); `backlog(tick)`: the pairs the live learner says it had yet to learn then."""
    writer = RunWriter(folder, "recorder", 10**9, 3600.0)
    writer.add_metadata("spaces dl/main", {"spaces": json.dumps(point.spaces.to_dict())})
    n_out, seq = point.spaces.output.dims, 0
    for tick in range(1, ticks + 1):
        x, stamp, ns = point.observe(), 1000 + tick / 30, tick * 10**7
        writer.write("dl/main/input", Input, encode(Input(tick, stamp, x)), ns, ns)
        writer.write("dl/main/proposal/learner/l", Proposal,
                     encode(Proposal(tick, "learner/l", np.zeros(n_out), 0.1, learned=seq, backlog=backlog(tick))),
                     ns + 1, ns + 1)
        taught = lesson(tick, x)
        y, mask = taught if taught is not None else (np.zeros(n_out), None)
        writer.write("dl/main/command", Command, encode(Command(tick, stamp, y, "student" if taught is None
                                                                else "teacher", "t", 1.0)), ns + 2, ns + 2)
        if taught is not None:
            seq += 1
            writer.write("dl/main/train", TrainingPair, encode(TrainingPair("e", seq, tick, x, y, "teacher/t", mask)),
                         ns + 3, ns + 3)
        point.step(y, 1 / 30)
    writer.close()
    return folder
