"""What every service shares about the bus, one room each:

    config.py      flags into a zenoh.Config (the one place a session's settings are made)
    lifecycle.py   stopping on signals or the supervisor's death, stack dumps, the log
    inbox.py       what a service hears: the inbox its callbacks feed, rejects with their reasons
    publishers.py  what it says: latest-only and lossless publishers, its status once a second
    queries.py     what it asks: the one owner of a key, the platform's spaces
    runtime.py     all of these for one box: its session, token, stop flag, inbox, rejects, counters and
                   status, handing the box its events (docs/adding-a-box.md)
"""
