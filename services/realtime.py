"""Low-latency mode: ask the kernel to keep CPUs out of deep idle states while we run.

A loop that ticks every 10 ms lets its processes sleep between ticks, and each wake-up from deep
idle costs a few hundred microseconds per hop (on this project's 2-core VMs about 0.2 ms of a
1.7 ms tick). Holding a PM QoS request of 0 µs on /dev/cpu_dma_latency (the standard real-time
Linux knob) trades power for latency. It lasts while the file stays open, i.e. this process's life.
"""
from __future__ import annotations

import logging
import os
import struct

_held: int | None = None


def hold_low_latency(log: logging.Logger | None = None) -> bool:
    """True if the request is held (needs write access to /dev/cpu_dma_latency, usually root)."""
    global _held
    if _held is not None:
        return True
    try:
        fd = os.open("/dev/cpu_dma_latency", os.O_WRONLY)
        os.write(fd, struct.pack("i", 0))
    except OSError as err:
        if log:
            log.warning("low latency not available (%s); ticks will pay idle wake-ups", err)
        return False
    _held = fd
    return True


def release_low_latency() -> None:
    """Drop the request (closing the file ends it): what runs next pays idle wake-ups, as by default."""
    global _held
    if _held is not None:
        os.close(_held)
        _held = None
