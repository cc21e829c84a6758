"""A default controller (Figure 1's): it answers each newest input with the middle of the output space,
so with no teacher and no sure learner the robot goes there. A box is its algorithm and one loop body."""
import argparse

import numpy as np

from bus_schema import InstanceKeys, Input, Proposal, encode
from services.bus.config import add_bus_args, config_from_args
from services.bus.inbox import decode_or_reject
from services.bus.runtime import BoxRuntime


def main(conf, instance: str = "main", name: str = "middle") -> int:
    with BoxRuntime(conf, InstanceKeys(instance), "default", name) as box:  # role default: its token says so
        spaces = box.fetch_spaces()  # the platform's, asked until it answers (None: stopped meanwhile)
        if spaces is None:
            return 0
        middle = (np.asarray(spaces.output.low) + np.asarray(spaces.output.high)) / 2
        proposals = box.sensor_publisher(box.keys.proposal("default", name))
        box.subscribe(box.keys.input, "input")
        for batch in box.batches(0.1):  # until stopped; the status goes out between batches
            newest = None
            for _, key, payload, _ in batch:  # latest-only: a stale input is not worth answering
                newest = decode_or_reject(Input, payload, key, box.rejects, {"x": spaces.input.dims}) or newest
            if newest is not None:
                proposals.put(encode(Proposal(newest.tick, f"default/{name}", middle, 1.0)))
                box.counts["proposals"] += 1
    return 0


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--instance", default="main")
    parser.add_argument("--name", default="middle")
    add_bus_args(parser)
    args = parser.parse_args()
    raise SystemExit(main(config_from_args(args), args.instance, args.name))
