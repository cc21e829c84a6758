"""Refusals read from Zenoh's log (issue 30): the lines a real router (eclipse-zenoh 1.10) wrote when an
identity on its roster and one not on it connected; only the second counts, by its name."""
import logging

from services.refusals import Refusals

ROUTER_LOG = """\
2026-11-27T00:32:59.914277Z DEBUG acc-0 ThreadId(06) zenoh_link_tls::unicast: Accepted TLS connection on \
127.0.0.1:17999: 127.0.0.1:41658. Common Name: operator.bob.
2026-11-27T00:32:59.916697Z DEBUG acc-0 ThreadId(06) zenoh_link_tls::unicast: Accepted TLS connection on \
127.0.0.1:17999: 127.0.0.1:41662. Common Name: teacher.eve.
2026-11-27T00:32:59.916978Z  INFO acc-0 ThreadId(06) zenoh::net::routing::interceptor::access_control: \
39e0f5d9cb1ce7d3980035d6cda9842f did not match any configured ACL subject. Default permission `Deny` will be \
applied on all messages
"""


def test_a_connection_off_the_roster_is_counted_by_its_name(caplog):
    refusals = Refusals(["router.router", "operator.bob"], "router", logging.getLogger("test"))
    with caplog.at_level(logging.WARNING):
        for line in ROUTER_LOG.splitlines():
            refusals.note(line)
    assert refusals.counts() == {"teacher.eve": 1}
    assert "router refused teacher.eve from 127.0.0.1:41662" in caplog.text


def test_a_router_certificate_not_the_routers_own_is_a_stranger_and_an_unnamed_refusal_still_counts():
    refusals = Refusals(["router.router", "router.mallet"], "platform", logging.getLogger("test"))
    refusals.note(ROUTER_LOG.splitlines()[0].replace("operator.bob", "router.mallet"))
    refusals.note(ROUTER_LOG.splitlines()[2])
    refusals.note(ROUTER_LOG.splitlines()[2])  # a link this process opened: no name was logged
    assert refusals.counts() == {"router.mallet": 1, "?": 1}
