"""What a service asks: a query answered by the one owner of a key, or a clear reason why not; the
platform's spaces, asked until it answers."""
from __future__ import annotations

import logging
import time

import zenoh

from bus_schema import SchemaError, Spaces, SpacesMessage, decode


def ask_owner(session: zenoh.Session, selector: str, timeout: float) -> tuple[bytes | None, str]:
    """Ask every queryable on `selector` (not the nearest only, so the owner is always asked) and
    take the answer if there is exactly one, or all answers are the same bytes: (payload, "").
    Otherwise (None, what went wrong): no answer, only errors, or answers that disagree, which
    means someone besides the owner answers on this key (without access control anyone may)."""
    answers, errors = set(), []
    for reply in session.get(selector, timeout=timeout, target=zenoh.QueryTarget.ALL,
                             consolidation=zenoh.ConsolidationMode.NONE):
        if reply.ok is not None:
            answers.add(reply.ok.payload.to_bytes())
        else:
            errors.append(reply.err.payload.to_bytes()[:200].decode("utf-8", "replace"))
    if len(answers) == 1:
        return answers.pop(), ""
    if answers:
        return None, f"{len(answers)} different answers on {selector}: someone besides its owner answers there"
    return None, f"error from {selector}: {errors[0]}" if errors else f"no answer on {selector}"


def fetch_spaces(session: zenoh.Session, key: str, stop, log: logging.Logger,
                 timeout: float | None = None) -> Spaces | None:
    """Ask the platform for its spaces on `key` (dl/<i>/spaces, robot/<r>/spaces) until it answers (dims
    come from the platform, not from flags). Every answer to one query must agree: spaces that a second
    answerer contradicts are not trusted (without access control anyone may answer; with it only the
    platform can), and the query is asked again."""
    start, warned, wait = time.monotonic(), False, 0.2
    while not stop:
        answers = []
        # every queryable, every answer: two answerers must both be heard to be compared. A session just
        # opened may not hear the end of its first query until the timeout (its links to the other peers
        # are still being made), so the wait starts short and grows (0.2 s, 0.4 s, ... 1.6 s: a radio link)
        for reply in session.get(key, timeout=wait, target=zenoh.QueryTarget.ALL,
                                 consolidation=zenoh.ConsolidationMode.NONE):
            if reply.ok is None:
                continue
            try:
                answers.append(Spaces.from_dict(decode(SpacesMessage, reply.ok.payload.to_bytes(), key).spaces))
            except (SchemaError, KeyError, TypeError, ValueError) as err:
                log.error("platform spaces rejected: %s", err)
        if answers and all(a.to_dict() == answers[0].to_dict() for a in answers[1:]):
            return answers[0]
        if answers:
            shapes = sorted({f"{a.input.dims} -> {a.output.dims}" for a in answers})
            log.error("%d answers on %s disagree (%s): trusting none, asking again", len(answers), key,
                      "; ".join(shapes) if len(shapes) > 1 else "same sizes, other bounds or names")
        if timeout is not None and time.monotonic() - start > timeout:
            return None
        wait = min(2 * wait, 1.6)
        if not warned and time.monotonic() - start > 3:
            log.info("waiting for the platform to answer on %s", key)
            warned = True
        time.sleep(0.1)
    return None
