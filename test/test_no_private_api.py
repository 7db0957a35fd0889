"""No private API of rclpy, numba or any other library in rigid_body_sim/.

Statically, over every module of the package: no attribute with a leading underscore read from
anything but ``self``/``cls`` (``node._parameter_overrides``...), no import of a module whose
path has a private part (``rclpy.impl.implementation_singleton``'s ``_rclpy``...), and none of
the known undocumented entry points (numba's ``Dispatcher.overloads`` / ``entry_point``)
anywhere. The compiled core reaches numba only through ``numba.njit`` (core/kernels/jit.py); no module
is exempt.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "rigid_body_sim"
MODULES = sorted(PACKAGE.rglob("*.py"))

#: Public-looking names that are undocumented internals of a library we use (numba's compiled
#: overloads, through which its entry points are reached; rclpy's C binding).
UNDOCUMENTED = {"overloads", "implementation_singleton", "rclpy_implementation"}
#: Underscore names the standard library documents as public (os._exit: exit without clean-up).
DOCUMENTED = {("os", "_exit")}


def own_private_names(modules: list[Path]) -> set[str]:
    """Underscore names our own package defines: ``self._x = ...`` and ``def _x`` in a class.

    One of our classes may read another instance of itself (``Simulator.with_scene`` fills the
    new simulator's buffers); that is our API, not a library's. A name a library keeps private
    (``_parameter_overrides``...) is refused here even if we defined it too (see the test).
    """
    names = set()
    for path in modules:
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ClassDef):
                for item in node.body:
                    if isinstance(item, ast.FunctionDef) and item.name.startswith("_"):
                        names.add(item.name)
            elif (isinstance(node, ast.Attribute) and isinstance(node.ctx, ast.Store)
                  and isinstance(node.value, ast.Name) and node.value.id == "self" and node.attr.startswith("_")):
                names.add(node.attr)
    return {name for name in names if not name.startswith("__")} - LIBRARY_PRIVATE


#: Private names of rclpy and numba the seed used (never ours, whatever we name our own).
LIBRARY_PRIVATE = {"_parameter_overrides", "_rclpy", "_take_subscription", "_dispatcher", "_cache"}


def private_uses(path: Path, own_names: set[str] | None = None) -> list[str]:
    """'line: expression' of every private or undocumented use in ``path``; ``own`` are the
    underscore names of our own classes (allowed on any instance of them)."""
    own_names = own_names or set()
    found = []
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute):
            own = (isinstance(node.value, ast.Name) and node.value.id in ("self", "cls")) or node.attr in own_names
            if isinstance(node.value, ast.Name) and (node.value.id, node.attr) in DOCUMENTED:
                continue
            if node.attr.startswith("_") and not node.attr.startswith("__") and not own:
                found.append(f"{node.lineno}: {ast.unparse(node)}")
            elif node.attr in UNDOCUMENTED and not own:
                found.append(f"{node.lineno}: {ast.unparse(node)}")
        elif isinstance(node, (ast.Import, ast.ImportFrom)):
            if isinstance(node, ast.ImportFrom) and (node.level > 0 or (node.module or "").startswith("rigid_body_sim")):
                continue  # our own modules' helpers are ours to use
            modules = [alias.name for alias in node.names] if isinstance(node, ast.Import) else [node.module or ""]
            names = [alias.name for alias in node.names] if isinstance(node, ast.ImportFrom) else []
            for module in modules:
                if any(part.startswith("_") and part != "__future__" for part in module.split(".")):
                    found.append(f"{node.lineno}: import {module}")
                if any(part in UNDOCUMENTED for part in module.split(".")):
                    found.append(f"{node.lineno}: import {module}")
            for name in names:
                if name.startswith("_") or name in UNDOCUMENTED:
                    found.append(f"{node.lineno}: from {modules[0]} import {name}")
    return found


@pytest.fixture(scope="module")
def own_names() -> set[str]:
    """own_private_names of the package, once per test process that runs these tests (not at collection)."""
    return own_private_names(MODULES)


def test_the_package_has_modules_to_check():
    assert len(MODULES) > 20 and PACKAGE / "ros" / "node.py" in MODULES


@pytest.mark.parametrize("path", MODULES, ids=[str(p.relative_to(PACKAGE)) for p in MODULES])
def test_no_private_api(path: Path, own_names: set[str]):
    assert private_uses(path, own_names) == []


def test_the_check_sees_what_it_must(tmp_path: Path):
    sample = tmp_path / "sample.py"
    sample.write_text(
        "from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy\n"
        "import numba._helperlib\n"
        "overrides = node._parameter_overrides\n"
        "fast = dispatcher.overloads[sig].entry_point\n"
        "from .closed_form import _jacobi\n"
        "own = self._lock\n"
        "other = new._Ys\n"
        "again = node._parameter_overrides\n"
    )
    found = private_uses(sample, own_private_names([sample]) | {"_Ys", "_parameter_overrides"} - LIBRARY_PRIVATE)
    assert sorted(line.split(":")[0] for line in found) == ["1", "1", "2", "3", "4", "8"]
