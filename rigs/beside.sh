#!/bin/sh
# beside.sh COMMAND...: COMMAND (make test's fast and slow tiers) at the lowest priority the live tier's services
# see: in a session of its own whose group is at nice 19 (Linux schedules each session as one group, and every
# service leads its own: a nice of its own would weigh only against its own session's), and at nice 19 where the
# kernel groups no sessions (services/priority.py). A session of its own changes nothing else here: make's
# background list ignores Ctrl-C either way.
if command -v setsid >/dev/null 2>&1; then
    exec setsid -w sh -c 'echo 19 > /proc/self/autogroup 2>/dev/null; exec nice -n 19 "$@"' beside "$@"
fi
exec nice -n 19 "$@"
