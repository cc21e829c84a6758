"""Each role says its part and no more (issue 30). For every role, a session with its certificate puts on,
holds a token on, asks and answers every key some role may (services/permissions.py, each '*' a name),
and a few wildcards, through a real router enforcing the allow-list: what passes is exactly what that
role's part includes. docs/security.md and services/security.py show the same table."""
import itertools
import re
import time
from dataclasses import fields

import pytest
import zenoh

import services.security
from rigs.harness import REPO
from services.permissions import PARTS, Part
from tests.test_security import secured_router, session_config

ROLES = [role for role in PARTS if role != "router"]
WILDCARDS = ("**", "dl/**", "dl/x/**", "dl/x/alive/**", "robot/**", "dogged/**")


def concrete(pattern: str) -> str:
    return "/".join("x" if chunk == "*" else chunk for chunk in pattern.split("/"))


def every(kind: str) -> list[str]:
    """A key for each key expression some role may use for `kind`: what each role is tried on."""
    return sorted({concrete(k) for role in ROLES for k in getattr(PARTS[role], kind)})


def allowed(role: str, kind: str, keys) -> list[str]:
    return sorted(k for k in keys if any(zenoh.KeyExpr(p).includes(k) for p in getattr(PARTS[role], kind)))


def first_role(kind: str, key: str) -> str:
    return next(role for role in ROLES if allowed(role, kind, [key]))


class Bystanders:
    """Who hears a role: a listener of every put and token, an owner answering each key (noting who asked),
    and for each key an identity that may ask it (noting who answered)."""

    def __init__(self, endpoint, directory):
        self.sessions = {}
        self.heard, self.tokens, self.called = [], [], []

        def session(cn):
            if cn not in self.sessions:
                self.sessions[cn] = zenoh.open(session_config(endpoint, directory, cn))
            return self.sessions[cn]
        listener = session("operator.listener")
        self.held = [listener.declare_subscriber("**", lambda s: self.heard.append(str(s.key_expr))),
                     listener.liveliness().declare_subscriber(
                         "**", lambda s: s.kind == zenoh.SampleKind.PUT and self.tokens.append(str(s.key_expr)))]
        for key in every("answer"):
            owner = first_role("answer", key)
            self.held.append(session(f"{owner}.{owner}").declare_queryable(
                key, lambda q, k=key: (self.called.append(str(q.key_expr)), q.reply(k, b"owner"))))
        self.askers = {key: session(f"{first_role('ask', key)}.asker") for key in every("answer")}

    def clear(self):
        for seen in (self.heard, self.tokens, self.called):
            seen.clear()

    def close(self):
        del self.held
        for session in self.sessions.values():
            session.close()


@pytest.fixture(scope="module")
def bus(tmp_path_factory):
    askers = {f"{first_role('ask', key)}.asker" for key in every("answer")}
    identities = ["router.router", "operator.listener", *askers, *(f"{role}.{role}" for role in ROLES)]
    with secured_router(tmp_path_factory, identities) as (endpoint, directory, _):
        bystanders = Bystanders(endpoint, directory)
        time.sleep(0.5)
        yield endpoint, directory, bystanders
        bystanders.close()


def replies(pending) -> dict[str, list[bytes]]:
    return {key: [r.ok.payload.to_bytes() for r in handler if r.ok is not None] for key, handler in pending.items()}


@pytest.mark.live
@pytest.mark.parametrize("role", ROLES)
def test_each_role_says_its_part_and_no_more(bus, role):
    endpoint, directory, by = bus
    by.clear()
    puts, tokens, asks = (every(kind) + list(WILDCARDS) for kind in ("put", "token", "ask"))
    with zenoh.open(session_config(endpoint, directory, f"{role}.{role}")) as session:
        time.sleep(0.5)
        for key in puts:
            session.put(key, b"x")
        held = [session.liveliness().declare_token(key) for key in tokens]
        asked = replies({key: session.get(key, target=zenoh.QueryTarget.ALL, timeout=1.0) for key in asks})
        held += [session.declare_queryable(key, lambda q, k=key: q.reply(k, role.encode())) for key in every("answer")]
        time.sleep(0.5)
        answered = replies({key: asker.get(key, target=zenoh.QueryTarget.ALL, timeout=1.0,
                                           consolidation=zenoh.ConsolidationMode.NONE)
                            for key, asker in by.askers.items()})
        del held
    said = {"put": sorted(set(by.heard)), "token": sorted(set(by.tokens)),
            "ask": sorted({k for k in by.called if b"owner" in asked.get(k, [])}),
            "answer": sorted(k for k, got in answered.items() if role.encode() in got)}
    assert said == {"put": allowed(role, "put", puts), "token": allowed(role, "token", tokens),
                    "ask": allowed(role, "ask", asks), "answer": allowed(role, "answer", every("answer"))}


def test_the_router_forwards_what_any_role_may_say_and_says_it_is_up():
    union = {kind: {k for role in ROLES for k in getattr(PARTS[role], kind)} for kind in ("put", "answer", "ask")}
    assert {kind: set(getattr(PARTS["router"], kind)) for kind in union} == union
    own = set(PARTS["router"].token) - {k for role in ROLES for k in PARTS[role].token}
    assert own == {"dogged/router", "dogged/router/*"}


ROW = re.compile(r"^\| (\w+) \| (put|token|answer|ask) \| (.*) \|$")


def expand(text: str) -> list[str]:
    """`dl/i/{a,b}/*` -> ['dl/*/a/*', 'dl/*/b/*']: the tables' shorthand (i: any instance, r: any robot)."""
    parts = re.split(r"\{([^}]*)\}", text)
    choices = [p.split(",") if i % 2 else [p] for i, p in enumerate(parts)]
    keys = ["".join(c) for c in itertools.product(*choices)]
    return [re.sub(r"^(dl/i|robot/r)/", lambda m: m.group(1)[:-1] + "*/", k) for k in keys]


def table(text: str) -> dict[str, dict[str, set[str]]]:
    said: dict[str, dict[str, set[str]]] = {}
    for line in text.splitlines():
        row = ROW.match(line.strip())
        if row:
            keys = said.setdefault(row.group(1), {}).setdefault(row.group(2), set())
            keys.update(k for quoted in re.findall(r"`([^`]+)`", row.group(3)) for k in expand(quoted))
    return said


@pytest.mark.parametrize("where", ["docs/security.md", "services/security.py"])
def test_the_security_page_and_the_docstring_show_the_allow_list(where):
    text = (REPO / where).read_text() if where.endswith(".md") else services.security.__doc__
    shown = table(text)
    assert {role: shown.get(role, {}) for role in ROLES} == {
        role: {kind: set(keys) for kind, keys in PARTS[role].kinds()} for role in ROLES}
    others = {k for role in ROLES for k in PARTS[role].token}
    assert shown["router"] == {"token": set(PARTS["router"].token) - others}
    assert [f.name for f in fields(Part)] == ["put", "token", "answer", "ask"]  # the kinds ROW reads
