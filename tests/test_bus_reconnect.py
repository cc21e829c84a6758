"""A service's session tries a lost router again within half a second (Zenoh's default backs off to 4 s): a router
killed and back had the sessions back a second after it, and the fault suite's 2 s recovery failed in CI."""
import json

from services.bus.config import CONNECT_RETRY, zenoh_config


def test_a_service_and_a_command_retry_the_router_every_half_second_at_most():
    for give_up_after in (None, 5.0):
        conf = zenoh_config(connect=["tcp/127.0.0.1:7447"], give_up_after=give_up_after)
        retry = json.loads(conf.get_json("connect/retry"))
        assert retry["period_max_ms"] <= 500 and retry["period_init_ms"] <= 100, retry
        assert retry == CONNECT_RETRY


def test_a_router_alone_connects_nowhere():
    conf = zenoh_config(mode="router", listen=["tcp/127.0.0.1:7447"])
    assert json.loads(conf.get_json("connect/endpoints")) == []
