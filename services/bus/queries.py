"""What a service asks: a query answered by the one owner of a key, or a clear reason why not."""
from __future__ import annotations

import zenoh


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
