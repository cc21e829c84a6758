"""The boxes: each services.boxes.<box> is a process with cli(argv) (`dogged run <box>`).

BOX_ROLES is the one list of them: the role each one's certificate carries (services/security.py).
"""
BOX_ROLES = {"router": "router", "platform": "platform", "aibo": "platform", "demonstrator": "teacher",
             "learner": "learner", "arbitrator": "arbitrator", "perception": "perception", "handler": "handler",
             "chain": "chain", "recorder": "recorder", "ui": "operator"}
