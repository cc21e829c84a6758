"""Turn off an interface's checksum and segmentation offloads (what `ethtool -K dev tx off` does).

A veth hands frames on with their TCP/UDP checksums left for the hardware to fill in; frames that
rigs/netlab/air.py reads and sends on again would then arrive with bad checksums and be dropped.
With transmit checksumming off, the kernel computes them before the frame leaves (and segments
large TCP sends itself). Run inside the interface's namespace: python -m rigs.netlab.offload eth0
"""
from __future__ import annotations

import ctypes
import fcntl
import socket
import struct
import sys

SIOCETHTOOL = 0x8946
ETHTOOL_SRXCSUM, ETHTOOL_STXCSUM, ETHTOOL_SSG, ETHTOOL_STSO, ETHTOOL_SGSO, ETHTOOL_SGRO = \
    0x15, 0x17, 0x19, 0x1f, 0x24, 0x2c


def set_feature(interface: str, command: int, on: bool) -> None:
    value = ctypes.create_string_buffer(struct.pack("II", command, int(on)))
    request = struct.pack("16sP", interface.encode(), ctypes.addressof(value))
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        fcntl.ioctl(s.fileno(), SIOCETHTOOL, request)


def offloads_off(interface: str) -> None:
    for command in (ETHTOOL_STSO, ETHTOOL_SGSO, ETHTOOL_SGRO, ETHTOOL_SSG, ETHTOOL_STXCSUM, ETHTOOL_SRXCSUM):
        try:
            set_feature(interface, command, False)
        except OSError as err:
            if command in (ETHTOOL_STXCSUM, ETHTOOL_STSO):  # the two that matter
                raise OSError(f"{interface}: cannot turn offload 0x{command:x} off: {err}") from None


if __name__ == "__main__":
    for name in sys.argv[1:]:
        offloads_off(name)
