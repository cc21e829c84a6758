"""What the tests and the benchmarks run the product in: not part of it (the wheel does not carry this
package; tests/test_wheel.py checks), so nothing in services or bus_schema imports it
(tests/test_import_graph.py).

    harness.py      real processes on a real router on loopback: `dogged ...`, a Probe of every status
    headless.py     the page in Debian's chromium, driven by Playwright
    tasks.py        learning tasks and their measures (cross, mirror samples, nMSE); lwpr_draws.py, the
                    draws the LWPR tests and the reference comparison share
    live/           the experiments other than the demo's ball seeking, live as processes over Zenoh
                    (mirroring, the two levels, ball seeking with its page); whether a learner caught up
    faults.py       every service struck in turn under a running deployment (issue 12); fuzz.py, ten
                    thousand hostile payloads at it
    hosts.py        mirroring spread over hosts (issue 13), on netlab/'s network namespaces
    imports.py      what a module imports, read with ast (the import graph's and the wheel's tests)
"""
