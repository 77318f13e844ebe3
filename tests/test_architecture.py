"""The architecture of SPEC §1 and §10, checked on the source: data flows one way
(``golden`` ← ``rtl_model`` → ``vectors``; ``tools`` orchestrates; ``guidance`` consumes
range points), no module imports another module's private name, and no import cycle.

The checks read every module of the installed packages with :mod:`ast` (imports inside
functions count too: a cycle hidden in a function is still a cycle of the design).
"""

from __future__ import annotations

import ast
from collections.abc import Iterator
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PACKAGES = ("golden", "rtl_model", "vectors", "guidance", "tools")
#: Package -> the packages it may import (itself included).
ALLOWED = {
    "golden": {"golden"},
    "rtl_model": {"golden", "rtl_model"},
    "vectors": {"golden", "rtl_model", "vectors"},
    "guidance": {"golden", "guidance"},
    "tools": set(PACKAGES),
}


def modules() -> dict[str, Path]:
    """Dotted module name (``rangefx.rtl_model.p1.model``) -> source file."""
    out = {}
    for pkg in PACKAGES:
        for path in sorted((ROOT / pkg).rglob("*.py")):
            parts = path.relative_to(ROOT).with_suffix("").parts
            if parts[-1] == "__init__":
                parts = parts[:-1]
            out[".".join(("rangefx", *parts))] = path
    return out


MODULES = modules()


def _resolve(module: str, node: ast.ImportFrom) -> str:
    """Absolute name of a ``from X import`` target seen in ``module``."""
    if node.level == 0:
        return node.module or ""
    is_pkg = MODULES[module].name == "__init__.py"
    base = module.split(".")
    base = base if is_pkg else base[:-1]
    base = base[: len(base) - (node.level - 1)]
    return ".".join([*base, node.module] if node.module else base)


def imports(module: str) -> Iterator[tuple[str, str | None, int]]:
    """(imported module, imported name or None, line) of every import in ``module``; a
    ``from package import submodule`` yields the submodule."""
    tree = ast.parse(MODULES[module].read_text(), filename=str(MODULES[module]))
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                yield alias.name, None, node.lineno
        elif isinstance(node, ast.ImportFrom):
            target = _resolve(module, node)
            for alias in node.names:
                sub = f"{target}.{alias.name}"
                if sub in MODULES:
                    yield sub, None, node.lineno
                else:
                    yield target, alias.name, node.lineno


def private_imports(module: str) -> list[str]:
    """Private names of *other* rangefx modules that ``module`` imports or reaches as
    ``other_module._name``."""
    bad = []
    aliases: dict[str, str] = {}
    for target, name, line in imports(module):
        if not target.startswith("rangefx.") or target == module:
            continue
        if name is None:
            aliases[target.rsplit(".", 1)[-1]] = target
        elif name.startswith("_") and not name.startswith("__"):
            bad.append(f"{MODULES[module].relative_to(ROOT)}:{line}: {target}.{name}")
    tree = ast.parse(MODULES[module].read_text())
    for node in ast.walk(tree):
        if (
            isinstance(node, ast.Attribute)
            and isinstance(node.value, ast.Name)
            and node.value.id in aliases
            and node.attr.startswith("_")
            and not node.attr.startswith("__")
        ):
            bad.append(
                f"{MODULES[module].relative_to(ROOT)}:{node.lineno}: "
                f"{aliases[node.value.id]}.{node.attr}"
            )
    return bad


def graph() -> dict[str, set[str]]:
    """Module -> the rangefx modules it imports (a package import counts its __init__)."""
    out: dict[str, set[str]] = {}
    for module in MODULES:
        deps = set()
        for target, _, _ in imports(module):
            if target in MODULES and target != module:
                deps.add(target)
        out[module] = deps
    return out


def find_cycle(g: dict[str, set[str]]) -> list[str] | None:
    """One import cycle of ``g`` (a list of modules, first = last), or None."""
    state: dict[str, int] = {}
    stack: list[str] = []

    def visit(node: str) -> list[str] | None:
        state[node] = 1
        stack.append(node)
        for dep in sorted(g[node]):
            # a package imported by its own submodule is initialised first: not a cycle
            if node.startswith(dep + "."):
                continue
            if state.get(dep) == 1:
                return [*stack[stack.index(dep) :], dep]
            if dep not in state:
                found = visit(dep)
                if found:
                    return found
        stack.pop()
        state[node] = 2
        return None

    for node in sorted(g):
        if node not in state:
            found = visit(node)
            if found:
                return found
    return None


def test_the_checks_see_every_package():
    for pkg in PACKAGES:
        assert any(m.startswith(f"rangefx.{pkg}.") for m in MODULES), pkg
    assert "rangefx.rtl_model.registry" in MODULES
    assert "rangefx.rtl_model.p1.model" in MODULES


@pytest.mark.parametrize("module", sorted(MODULES))
def test_no_private_name_of_another_module(module):
    assert private_imports(module) == []


def test_no_import_cycle():
    assert find_cycle(graph()) is None


@pytest.mark.parametrize("module", sorted(MODULES))
def test_data_flows_one_way(module):
    pkg = module.split(".")[1]
    used = {t.split(".")[1] for t, _, _ in imports(module) if t.startswith("rangefx.")}
    assert used <= ALLOWED[pkg], f"{module} imports {sorted(used - ALLOWED[pkg])}"


# -- the checks can fail -----------------------------------------------------------------
def test_cycle_finder_finds_a_planted_cycle():
    g = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": set()}
    assert find_cycle(g) == ["a", "b", "c", "a"]
    assert find_cycle({"a": {"b"}, "b": set()}) is None


def test_private_check_flags_a_planted_import(tmp_path, monkeypatch):
    fake = tmp_path / "mod.py"
    fake.write_text(
        "from rangefx.rtl_model.p1 import model\n"
        "from rangefx.rtl_model.runtime import _I64\n"
        "x = model._SIG\n"
    )
    monkeypatch.setitem(MODULES, "rangefx.tools.fake", fake)
    monkeypatch.setattr("test_architecture.ROOT", tmp_path)
    found = private_imports("rangefx.tools.fake")
    assert found == [
        "mod.py:2: rangefx.rtl_model.runtime._I64",
        "mod.py:3: rangefx.rtl_model.p1.model._SIG",
    ]


# -- the tests themselves: helper modules, never another test module ----------------------
TESTS = ROOT / "tests"


def faults_of_test_file(path: Path) -> list[str]:
    """Where a file of ``tests/`` imports a test module (``test_*``, its own name
    included) or edits ``sys.path``: helpers live in plain modules (``tests/conftest.py``)."""
    bad = []
    for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
        names = []
        if isinstance(node, ast.Import):
            names = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module:
            names = [node.module]
        for name in names:
            if name.split(".")[-1].startswith("test_") or name.startswith("tests."):
                bad.append(f"{path.name}:{node.lineno}: imports {name}")
        # sys.path.insert(...) and the like, or an assignment to sys.path (reading it,
        # say for a child process's PYTHONPATH, is fine)
        edited = [node.func.value] if isinstance(node, ast.Call) and isinstance(
            node.func, ast.Attribute) else []  # fmt: skip
        if isinstance(node, (ast.Assign, ast.AugAssign)):
            edited = node.targets if isinstance(node, ast.Assign) else [node.target]
            edited = [t.value if isinstance(t, ast.Subscript) else t for t in edited]
        if any(_is_sys_path(e) for e in edited):
            bad.append(f"{path.name}:{node.lineno}: edits sys.path")
    return sorted(bad, key=lambda b: int(b.split(":")[1]))


def _is_sys_path(node: ast.AST) -> bool:
    return (
        isinstance(node, ast.Attribute)
        and node.attr == "path"
        and isinstance(node.value, ast.Name)
        and node.value.id == "sys"
    )


@pytest.mark.parametrize("path", sorted(TESTS.glob("*.py")), ids=lambda p: p.name)
def test_no_test_imports_a_test_module_or_patches_sys_path(path):
    assert faults_of_test_file(path) == []


def test_the_test_module_check_flags_planted_faults(tmp_path):
    fake = tmp_path / "test_fake.py"
    fake.write_text(
        "import sys\n"
        "from test_bitexact import assert_bit_exact\n"
        "import test_compile as t\n"
        "sys.path.insert(0, '.')\n"
        "from bitexact_cases import p1_case\n"
        "env = {'PYTHONPATH': ':'.join(sys.path)}\n"
        "sys.path[0:0] = ['x']\n"
    )
    assert faults_of_test_file(fake) == [
        "test_fake.py:2: imports test_bitexact",
        "test_fake.py:3: imports test_compile",
        "test_fake.py:4: edits sys.path",
        "test_fake.py:7: edits sys.path",
    ]
