"""The wheel `pip wheel` builds from this tree (a copy of it: an old build/ folder would leak into it) carries
the product, services and bus_schema, with the deploy profiles, and none of what the tests and benchmarks
run it in: every module it carries is one `dogged` runs (reached from services.cli or a box, through
imports and the modules the product starts by name: a verb's, a registry's entry, `python -m`), or is in
SHIPPED_UNRUN, saying why."""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path, PurePosixPath

import pytest

from rigs.imports import imported, module_name, named_in_strings, within

pytestmark = pytest.mark.live  # pip builds the wheel in a process of its own

REPO = Path(__file__).resolve().parents[1]
LEFT_OUT_OF_THE_COPY = (".git", ".venv*", "build", "*.egg-info", "runs", "__pycache__", ".pytest_cache")

SHIPPED_UNRUN = {
    # what a new part is held to, shipped as river ships its checks and Gymnasium its env checker
    "services.learners.checks": "the learners' conformance checks",
    "services.learners.checks_tasks": "the learners' conformance checks on tasks",
    "services.learners.closed_loop": "the learners' checks' closed-loop task",
    "services.platforms.base": "the platform contract",
    "services.platforms.checks": "the platforms' conformance checks",
    "services.platforms.aibo.model.build_urdf": "writes aibo.urdf after its figures change",
    # the paper's other experiments in one process, beside the ball seeking `dogged demo` runs on:
    # benchmarks/ prints their figures
    "services.experiments.gym": "Gymnasium tasks taught and judged closed-loop",
    "services.experiments.hierarchy": "ball seeking over a learned gait",
    "services.experiments.mirroring": "section V.A",
    "services.experiments.unknown": "a task nobody tuned for",
    "services.experiments.walk": "the walk level",
}


@pytest.fixture(scope="module")
def wheel(tmp_path_factory) -> Path:
    tmp = tmp_path_factory.mktemp("wheel")
    source, out = tmp / "source", tmp / "wheel"
    shutil.copytree(REPO, source, symlinks=True, ignore=shutil.ignore_patterns(*LEFT_OUT_OF_THE_COPY))
    built = subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--quiet", "-w", str(out),
                            str(source)], capture_output=True, text=True, timeout=600)
    assert built.returncode == 0, built.stdout + built.stderr
    return next(out.glob("dogged-*.whl"))


def contents(path: Path) -> dict[str, bytes]:
    with zipfile.ZipFile(path) as whl:
        return {name: whl.read(name) for name in whl.namelist()}


def python_modules(files: dict[str, bytes]) -> dict[str, tuple[str, bool]]:
    """module -> (its source, whether it is a package)"""
    return {module_name(PurePosixPath(name)): (text.decode(), name.endswith("/__init__.py"))
            for name, text in files.items() if name.endswith(".py")}


def run_by_dogged(modules: dict[str, tuple[str, bool]]) -> set[str]:
    """The modules `dogged` and the boxes it starts reach: imported, their packages, and started by name."""
    todo = ["services.cli", *(m for m in modules if m.startswith("services.boxes."))]
    reached = set()
    while todo:
        module = todo.pop()
        if module in reached:
            continue
        reached.add(module)
        source, is_package = modules[module]
        names = imported(source, module, is_package) | named_in_strings(source, "services")
        packages = {".".join(module.split(".")[:i]) for i in range(1, module.count(".") + 1)}
        todo += within(names, modules) | packages
    return reached


def test_the_wheel_carries_services_and_bus_schema_only(wheel):
    tops = {name.split("/")[0] for name in contents(wheel) if not name.split("/")[0].endswith(".dist-info")}
    assert tops == {"services", "bus_schema"}, tops


def test_every_module_the_wheel_carries_is_run_by_dogged_or_says_why(wheel):
    modules = python_modules(contents(wheel))
    unrun = set(modules) - run_by_dogged(modules)
    unsaid = sorted(unrun - set(SHIPPED_UNRUN))
    assert not unsaid, f"the wheel carries modules `dogged` never runs (move them to rigs/, or say why): {unsaid}"
    stale = sorted(set(SHIPPED_UNRUN) - unrun)
    assert not stale, f"SHIPPED_UNRUN names what is not shipped, or is run after all: {stale}"


def test_the_wheel_carries_every_deploy_profile_and_finds_it_installed(wheel, tmp_path):
    files = contents(wheel)
    for profile in sorted((REPO / "deploy").glob("*.toml")):
        assert files.get(f"services/profiles/{profile.name}") == profile.read_bytes(), profile.name
    with zipfile.ZipFile(wheel) as whl:
        whl.extractall(tmp_path / "site")
    # the wheel's services first on the path: the profiles found where an installed dogged finds them
    found = subprocess.run([sys.executable, "-c", "import services, services.profiles as p; "
                            "from services.experiments.wiring import wired_learner; "
                            "print(services.__file__); print(p.profile_names()); print(wired_learner('ballseek'))"],
                           cwd=tmp_path, env={**os.environ, "PYTHONPATH": str(tmp_path / "site")},
                           capture_output=True, text=True, timeout=120)
    assert found.returncode == 0, found.stderr
    where, names, learner = found.stdout.splitlines()
    assert where == str(tmp_path / "site" / "services" / "__init__.py")
    assert names == str(sorted(p.stem for p in (REPO / "deploy").glob("*.toml")))
    assert learner == "('gp', {'near': 0.2})"


def test_what_dogged_runs_is_read_through_imports_and_names():
    modules = {"services.cli": ("from services.boxes import BOX_ROLES\nOWN = {'x': ('services.y', 'cli')}\n", False),
               "services.boxes": ("", True), "services.boxes.a": ("'''services.z is named in a docstring'''", False),
               "services.y": ("from .w import f\n", False), "services.w": ("", False), "services.z": ("", False),
               "services": ("", True)}
    assert run_by_dogged(modules) == set(modules) - {"services.z"}
