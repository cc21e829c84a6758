"""The simulated Sony Aibo ERS-7 (PyBullet). Importing this package does not import pybullet:
`JOINT_NAMES` and `JOINT_LIMITS` are cheap for any process that only needs the motor layout."""
from services.platforms.aibo.joints import JOINT_INDEX, JOINT_LIMITS, JOINT_NAMES

__all__ = ["JOINT_INDEX", "JOINT_LIMITS", "JOINT_NAMES"]
