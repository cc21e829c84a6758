"""What a module of ours uses, read from its source with ast (nothing is imported): tests/test_import_graph.py
reads the repository's modules, tests/test_wheel.py the wheel's."""
from __future__ import annotations

import ast
import re
from pathlib import PurePath


def module_name(relative: PurePath) -> str:
    """services/bus/inbox.py -> services.bus.inbox; services/bus/__init__.py -> services.bus."""
    parts = relative.with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def imported(source: str, module: str, is_package: bool) -> set[str]:
    """The dotted names the `import` and `from ... import` statements of `source` name, wherever they stand
    (in a function too), relative ones resolved: `from a import b` names a.b, which may be a module of a
    or a name in it (`within` then finds a)."""
    package = module if is_package else module.rpartition(".")[0]
    names = set()
    for node in ast.walk(ast.parse(source, module)):
        if isinstance(node, ast.Import):
            names |= {alias.name for alias in node.names}
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                up = package.split(".")[:len(package.split(".")) - node.level + 1]
                base = ".".join(up + ([node.module] if node.module else []))
            names |= {f"{base}.{alias.name}" for alias in node.names}
    return names


def named_in_strings(source: str, root: str) -> set[str]:
    """The dotted names under `root` written in the code's strings, not its docstrings: the modules it starts
    by name (a registry's "services.platforms.point:PointPlatform", `python -m services.cli`)."""
    tree = ast.parse(source)
    docstrings = {id(node.value) for node in ast.walk(tree) if isinstance(node, ast.Expr)}
    pattern = re.compile(rf"\b{re.escape(root)}(?:\.\w+)+")
    return {found for node in ast.walk(tree) if isinstance(node, ast.Constant) and isinstance(node.value, str)
            and id(node) not in docstrings for found in pattern.findall(node.value)}


def within(names: set[str], modules) -> set[str]:
    """The modules of `modules` that `names` are, or lie in (a class of one, say); another project's
    names give none."""
    found = set()
    for name in names:
        while name and name not in modules:
            name = name.rpartition(".")[0]
        if name:
            found.add(name)
    return found
