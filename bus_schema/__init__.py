"""The bus contract: keys, payloads, spaces. Imports nothing else of the project."""
from .codec import VERSION, decode, decoded, encode, pack_vector, unpack_vector
from .errors import SchemaError
from .keys import (EVERY_ALIVE, EVERY_STATUS, ROUTER, InstanceKeys, RobotKeys, check_name, is_name, router_token,
                   supervisor_key, supervisor_token)
from .messages import (MODES, Applied, ArenaReset, Clock, Command, ControlReply, Episode, Frame, Handle, Input,
                       PairBatch, Proposal, RecordSwitch, Reward, RobotState, SelectLearner, Snapshot, SpacesMessage,
                       Status, TeachSwitch, TrainingPair)
from .spaces import Box, Spaces

__all__ = ["VERSION", "decode", "decoded", "encode", "pack_vector", "unpack_vector", "SchemaError", "InstanceKeys",
           "check_name", "is_name", "supervisor_key", "supervisor_token", "router_token", "ROUTER", "EVERY_ALIVE",
           "EVERY_STATUS", "MODES", "Applied", "Command", "ControlReply", "RobotKeys", "ArenaReset",
           "Clock", "Episode", "Frame", "Handle", "RecordSwitch", "Reward", "RobotState", "Input", "PairBatch",
           "Proposal", "SelectLearner", "Snapshot", "SpacesMessage", "Status", "TeachSwitch", "TrainingPair", "Box",
           "Spaces"]
