"""The import graph, read from the source with ast (nothing is imported): every module of the product
(bus_schema, services), of the rigs, the tests and the benchmarks sits in one layer of LAYERS and imports
only from its own layer and those below it; no two packages import each other, however far round; tests
and benchmarks share the rigs, never each other. A module in no layer fails: a new package says here
where it sits.

Read are `import` and `from ... import` statements wherever they stand (in a function too). Not read
are modules reached by name at run time: a box by `dogged run <box>` and the supervisor, a platform by
its registry entry, a verb by the CLI's table, `python -m`: that is how the CLI and the registries start
what sits above them without importing it."""
from __future__ import annotations

import functools
from pathlib import Path

from rigs.imports import imported, module_name, within

REPO = Path(__file__).resolve().parents[1]
ROOTS = ("bus_schema", "services", "rigs", "tests", "benchmarks")

# lowest first. A package of services (services.<name>, a folder or one file) is a unit; every other root
# is one unit. services itself is its __init__ (one BLAS thread per process).
LAYERS: tuple[tuple[str, tuple[str, ...]], ...] = (
    ("bus_schema", ("bus_schema",)),  # the contract: messages, keys, spaces; imports nothing of ours
    # what everything may use: argument parsing, waiting, the low-latency request, the CPUs a process runs on,
    # the profiles (data), how much of a contended CPU background work takes
    ("base", ("services", "services.allocator", "services.params", "services.waiting", "services.realtime",
              "services.placement", "services.priority", "services.profiles")),
    # plain Python, no bus: learners, teachers, arbitration, perception, the robots, the recording files
    # (MCAP: what the recorder writes and replays read; the recorded platform), a chain's spaces and
    # easing, a learner's pair log
    ("algorithms", ("services.arbitration", "services.learners", "services.perception", "services.teachers",
                    "services.platforms", "services.recording", "services.chaining", "services.pairlog")),
    # who may speak on the bus: certificates, roles and their permissions, this user's own identities
    ("trust", ("services.permissions", "services.security", "services.refusals", "services.certificates",
               "services.own_identities")),
    # a session's settings, inbox, publishers, queries; what the CLI and the page ask a supervisor (control.py)
    ("bus", ("services.bus",)),
    ("boxes", ("services.boxes",)),  # each a process wrapping one algorithm
    ("supervisor", ("services.supervisor",)),  # profiles, their processes, the verbs it answers
    # the paper's experiments in one process; above the supervisor, whose parser reads the learner a profile
    # wires (experiments/wiring.py)
    ("experiments", ("services.experiments",)),
    # the "recording" layer: a recording used again, learners retrained and compared (`dogged
    # replay`), its inputs played into a bus (`dogged play`, the platform box). The files themselves sit
    # with the algorithms: the recorder box writes them
    ("replay", ("services.replay",)),
    # the page, and its box (which serves it); it reaches the supervisor over the bus (services.bus.control)
    ("page", ("services.ui", "services.boxes.ui")),
    ("verbs", ("services.cli", "services.export", "services.demo")),  # `dogged`, export, the headline demo
    ("rigs", ("rigs",)),  # what tests and benchmarks run the product in; not in the wheel (test_wheel.py)
    ("tests", ("tests", "benchmarks")),
)
NEITHER_IMPORTS_THE_OTHER = (("tests", "benchmarks"),)  # both take their harness from the rigs


@functools.cache
def modules() -> dict[str, Path]:
    return {module_name(p.relative_to(REPO)): p for root in ROOTS for p in sorted((REPO / root).rglob("*.py"))}


def unit(module: str) -> str:
    parts = module.split(".")
    return ".".join(parts[:2]) if parts[0] == "services" else parts[0]


def layer_of(module: str) -> str | None:
    """The layer of the module itself where LAYERS names it (services.boxes.ui), else of its unit."""
    for name in (module, unit(module)):
        for layer, units in LAYERS:
            if name in units:
                return layer
    return None


def imports_of(module: str) -> set[str]:
    path = modules()[module]
    return within(imported(path.read_text(), module, path.name == "__init__.py"), modules()) - {module}


@functools.cache
def graph() -> dict[str, set[str]]:
    return {module: imports_of(module) for module in modules()}


def test_every_module_sits_in_a_layer():
    known = {name for _, units in LAYERS for name in units}
    missing = sorted(m for m in modules() if layer_of(m) is None)
    assert not missing, f"in no layer of LAYERS (say where they sit): {missing}"
    empty = sorted(name for name in known if not any(name in (m, unit(m)) for m in modules()))
    assert not empty, f"LAYERS names what does not exist: {empty}"


def test_no_import_goes_up_a_layer():
    rank = {layer: i for i, (layer, _) in enumerate(LAYERS)}
    upward = [f"{m} ({layer_of(m)}) imports {d} ({layer_of(d)})"
              for m, deps in sorted(graph().items()) for d in sorted(deps)
              if layer_of(m) and layer_of(d) and rank[layer_of(d)] > rank[layer_of(m)]]
    assert not upward, "imports from a lower layer to a higher one:\n" + "\n".join(upward)


def unit_graph() -> dict[str, dict[str, list[str]]]:
    """unit -> unit it imports -> the imports that make the arrow (module -> module)."""
    arrows: dict[str, dict[str, list[str]]] = {}
    for m, deps in graph().items():
        for d in deps:
            if unit(d) != unit(m):
                arrows.setdefault(unit(m), {}).setdefault(unit(d), []).append(f"{m} -> {d}")
    return arrows


def cycles(arrows: dict[str, dict[str, list[str]]]) -> list[list[str]]:
    """Every strongly connected group of more than one unit (Tarjan's algorithm): units that import each
    other, however far round."""
    index, low, stack, on_stack, groups = {}, {}, [], set(), []

    def visit(u: str) -> None:
        index[u] = low[u] = len(index)
        stack.append(u), on_stack.add(u)
        for v in arrows.get(u, {}):
            if v not in index:
                visit(v)
                low[u] = min(low[u], low[v])
            elif v in on_stack:
                low[u] = min(low[u], index[v])
        if low[u] == index[u]:
            group = []
            while not group or group[-1] != u:
                group.append(stack.pop())
                on_stack.discard(group[-1])
            if len(group) > 1:
                groups.append(sorted(group))
    for u in sorted(arrows):
        if u not in index:
            visit(u)
    return groups


def test_no_packages_import_each_other():
    arrows = unit_graph()
    found = cycles(arrows)
    explained = [" <-> ".join(group) + ": " + "; ".join(sorted(e for a in group for b in group if b in arrows.get(a, {})
                                                              for e in arrows[a][b][:1]))
                 for group in found]
    assert not found, "packages that import each other:\n" + "\n".join(explained)


def test_tests_and_benchmarks_share_the_rigs_not_each_other():
    arrows = unit_graph()
    crossing = [e for a, b in NEITHER_IMPORTS_THE_OTHER for x, y in ((a, b), (b, a))
                for e in arrows.get(x, {}).get(y, [])]
    assert not crossing, "\n".join(crossing)


def test_the_graph_is_read():
    """The reading itself: relative imports, a module imported from its package, a function's import."""
    assert "bus_schema.codec" in graph()["bus_schema"]  # from .codec import ... in bus_schema/__init__.py
    assert "services.learners.registry" in graph()["services.learners"]
    assert "services.supervisor.commands" in graph()["services.cli"]  # imported inside main()
    assert layer_of("services.boxes.ui") == "page" and layer_of("services.boxes.learner") == "boxes"
    assert cycles({"a": {"b": []}, "b": {"c": []}, "c": {"a": []}, "d": {"a": []}}) == [["a", "b", "c"]]
