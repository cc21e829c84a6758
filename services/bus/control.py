"""What the CLI and the page ask a running profile's supervisor, over the keys bus_schema names for it
(supervisor_token, supervisor_key): which profile runs, and a verb's reply."""
from __future__ import annotations

from bus_schema import ControlReply, SchemaError, decode, supervisor_key, supervisor_token
from services.bus.queries import ask_owner


def running_profile(session, several_hint: str = "") -> tuple[str | None, str]:
    """The one profile whose supervisor runs on this bus: (name, "") or (None, why not; with several,
    followed by `several_hint`)."""
    names = sorted({str(r.ok.key_expr).split("/")[-1]
                    for r in session.liveliness().get(supervisor_token("*"), timeout=2.0) if r.ok is not None})
    if len(names) == 1:
        return names[0], ""
    return None, "no running profile found" if not names else f"several profiles run ({', '.join(names)}){several_hint}"


def ask_supervisor(session, profile: str, verb: str, parameters: str = "",
                   timeout: float = 5.0) -> tuple[ControlReply | None, str]:
    """A verb asked of `profile`'s supervisor: (its reply, "") or (None, what went wrong)."""
    key = supervisor_key(profile, verb)
    payload, problem = ask_owner(session, f"{key}?{parameters}" if parameters else key, timeout)
    if payload is None:
        return None, f"the supervisor of {profile} did not answer {verb}: {problem}"
    try:
        return decode(ControlReply, payload, key), ""
    except SchemaError as err:
        return None, f"bad reply: {err}"
