"""bus_schema/README.md documents every message and every key that exists."""
import inspect

import bus_schema
from bus_schema import InstanceKeys, RobotKeys, messages
from rigs.harness import REPO


def test_every_message_class_is_documented():
    doc = (REPO / "bus_schema" / "README.md").read_text()
    classes = [name for name, obj in inspect.getmembers(messages, inspect.isclass) if hasattr(obj, "FIELDS")]
    assert len(classes) >= 17
    missing = [name for name in classes if f"**{name}**" not in doc]
    assert missing == [], f"undocumented payloads: {missing}"


def test_every_key_is_documented():
    doc = (REPO / "bus_schema" / "README.md").read_text()
    i, r = InstanceKeys("i"), RobotKeys("r")
    keys = [v for v in vars(i).values() if isinstance(v, str) and v.startswith("dl/")]
    keys += [i.proposal("teacher", "<name>"), i.proposal("learner", "<name>"), i.alive("<role>", "<name>"),
             i.teaching("<name>"), i.commanding("<name>"), i.status("<role>", "<name>"), i.snapshot("<name>"),
             i.history("<name>")]
    keys += [v for v in vars(r).values() if isinstance(v, str) and v.startswith("robot/")]
    documented = [k.replace("dl/i/", "dl/<i>/").replace("robot/r/", "robot/<r>/") for k in keys
                  if not k.endswith("/**") and k not in (i.prefix, r.prefix)]
    missing = [k for k in documented if f"`{k}`" not in doc]
    assert missing == [], f"undocumented keys: {missing}"
    assert bus_schema.supervisor_key("p", "ps").replace("/p/", "/<profile>/") in doc
