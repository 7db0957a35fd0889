"""The core stays ROS-free: no module under rigid_body_sim/core imports rclpy or a *_msgs package.

Checked twice. Statically, every file under the core is parsed and every ``import`` and
``from … import`` (at any depth: functions, ``if TYPE_CHECKING``, ``try``) is inspected, so a
deferred import inside a function is caught too. Dynamically, the core and each of its modules
are imported in a fresh interpreter and its ``sys.modules`` is searched, which also catches an
import smuggled in through a third-party package or ``importlib``.
"""

from __future__ import annotations

import ast
import json
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
CORE = REPO / "rigid_body_sim" / "core"
CORE_FILES = sorted(CORE.rglob("*.py"))

#: Third-party top-level packages the core may import (convention 1: numpy and scipy; PyYAML,
#: deferred, to read scene files; numba, only in the compiled per-body modules listed in
#: core/kernels/, which earned it by the measured per-body cost). Everything else must be the standard library or the core.
ALLOWED_THIRD_PARTY = {"numpy", "scipy", "yaml", "numba"}


def _is_ros(module: str) -> bool:
    top = module.split(".")[0]
    return top == "rclpy" or top.endswith("_msgs") or top.startswith("rcl") or top == "rosidl_runtime_py"


def _imports(path: Path) -> list[tuple[int, str]]:
    """(line, absolute module name) of every import in ``path``; relative imports are skipped."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found.extend((node.lineno, alias.name) for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            found.append((node.lineno, node.module))
        elif isinstance(node, ast.Call) and getattr(node.func, "attr", getattr(node.func, "id", None)) in (
            "import_module", "__import__"
        ):
            for arg in node.args[:1]:
                if isinstance(arg, ast.Constant) and isinstance(arg.value, str):
                    found.append((node.lineno, arg.value))
    return found


def test_the_core_has_modules_to_check() -> None:
    names = {p.name for p in CORE_FILES}
    assert {"__init__.py", "quaternion.py", "dynamics.py", "integrators.py", "simulator.py", "scene.py", "layout.py",
            "stepping.py"} <= names


@pytest.mark.parametrize("path", CORE_FILES, ids=[str(p.relative_to(CORE)) for p in CORE_FILES])
def test_no_ros_import_statically(path: Path) -> None:
    ros = [f"{path.name}:{line}: {module}" for line, module in _imports(path) if _is_ros(module)]
    assert not ros, f"the core must not import ROS packages: {ros}"


@pytest.mark.parametrize("path", CORE_FILES, ids=[str(p.relative_to(CORE)) for p in CORE_FILES])
def test_only_numpy_scipy_yaml_numba_and_the_standard_library(path: Path) -> None:
    foreign = [
        f"{path.name}:{line}: {module}"
        for line, module in _imports(path)
        if module.split(".")[0] not in sys.stdlib_module_names
        and module.split(".")[0] not in ALLOWED_THIRD_PARTY
        and module.split(".")[0] != "rigid_body_sim"
    ]
    assert not foreign, f"the core imports only {sorted(ALLOWED_THIRD_PARTY)} and the standard library: {foreign}"


def test_the_static_check_sees_deferred_and_aliased_imports(tmp_path: Path) -> None:
    """The checker itself: it must find imports hidden inside functions, try blocks and importlib."""
    sample = tmp_path / "sample.py"
    sample.write_text(
        "import numpy as np\n"
        "from . import sibling\n"
        "def f():\n"
        "    import rclpy.node\n"
        "    try:\n"
        "        from geometry_msgs.msg import Pose\n"
        "    except ImportError:\n"
        "        pass\n"
        "    importlib.import_module('std_msgs.msg')\n",
        encoding="utf-8",
    )
    found = [module for _line, module in _imports(sample) if _is_ros(module)]
    assert found == ["rclpy.node", "geometry_msgs.msg", "std_msgs.msg"]


def test_no_ros_module_is_loaded_by_importing_the_core() -> None:
    modules = ["rigid_body_sim.core"] + [
        "rigid_body_sim.core." + ".".join(p.relative_to(CORE).with_suffix("").parts).removesuffix(".__init__")
        for p in CORE_FILES if p != CORE / "__init__.py"
    ]
    program = (
        "import importlib, json, sys\n"
        f"for name in {modules!r}:\n"
        "    importlib.import_module(name)\n"
        "import rigid_body_sim.core as core\n"
        "core.Simulator(core.load_scene({'bodies': {'b': {'mass': 1.0, 'inertia': {'sphere': 1.0}}}})).step(2)\n"
        "print(json.dumps(sorted(sys.modules)))\n"
    )
    result = subprocess.run(
        [sys.executable, "-c", program], cwd=REPO, capture_output=True, text=True, timeout=60,
        env={"PATH": "/usr/bin:/bin", "PYTHONPATH": str(REPO)},
    )
    assert result.returncode == 0, result.stderr
    loaded = json.loads(result.stdout.strip().splitlines()[-1])
    assert set(modules) <= set(loaded)
    ros = [m for m in loaded if _is_ros(m)]
    assert not ros, f"importing the core loaded ROS modules: {ros}"
    references = [m for m in loaded if m.startswith("rigid_body_sim.exact")]
    assert not references, f"stepping the core loaded the exact references: {references}"


#: Where every compiled (numba) module lives: the one folder the kernel cache depends on (kernels/jit.py).
KERNELS = CORE / "kernels"


def test_numba_only_under_kernels() -> None:
    users = sorted(str(path.relative_to(CORE)) for path in CORE_FILES
                   if any(module.split(".")[0] == "numba" for _line, module in _imports(path)))
    outside = [name for name in users if not name.startswith("kernels/")]
    assert users and not outside, f"numba is imported outside core/kernels/: {outside}"


def _relative_targets(path: Path) -> list[tuple[int, tuple[str, ...]]]:
    """(line, imported module as name parts) of every import of the package in ``path``, relative ones resolved."""
    return _relative_targets_of_text(path, path.read_text(encoding="utf-8"))


def _relative_targets_of_text(path: Path, text: str) -> list[tuple[int, tuple[str, ...]]]:
    package = path.relative_to(REPO).with_suffix("").parts[:-1]
    found = []
    for node in ast.walk(ast.parse(text)):
        if isinstance(node, ast.ImportFrom) and node.level:
            base = package[:len(package) - node.level + 1]
            if node.module:
                found.append((node.lineno, base + tuple(node.module.split("."))))
            else:
                found.extend((node.lineno, base + (alias.name,)) for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("rigid_body_sim"):
            found.append((node.lineno, tuple(node.module.split("."))))
        elif isinstance(node, ast.Import):
            found.extend((node.lineno, tuple(a.name.split("."))) for a in node.names if a.name.startswith("rigid_body_sim"))
    return found


@pytest.mark.parametrize("path", sorted(KERNELS.rglob("*.py")), ids=lambda p: str(p.relative_to(KERNELS)))
def test_kernels_import_nothing_else_of_the_package(path: Path) -> None:
    """What the compiled code is built from is all under kernels/, so the cache's stamp of that folder covers it."""
    inside = KERNELS.relative_to(REPO).parts
    foreign = [f"{path.name}:{line}: {'.'.join(target)}" for line, target in _relative_targets(path)
               if target[:len(inside)] != inside]
    assert not foreign, f"core/kernels/ imports only itself: {foreign}"


def test_numba_cache_is_dropped_when_any_kernel_source_changes(tmp_path: Path) -> None:
    """numba checks a cached function against its own file only; the kernels' guard checks them all."""
    from rigid_body_sim.core.kernels.jit import STAMP_NAME, invalidate_stale_cache

    sources, cache = tmp_path / "core", tmp_path / "core" / "__pycache__"
    sources.mkdir()
    (sources / "integrators.py").write_text("A = 1\n")
    (sources / "stepping.py").write_text("B = 2\n")
    cache.mkdir()
    cached = [cache / "stepping.advance-1.py311.nbi", cache / "stepping.advance-1.py311.1.nbc"]

    def fill() -> None:
        for path in cached:
            path.write_bytes(b"machine code")

    fill()
    assert invalidate_stale_cache(sources, cache)  # no stamp yet: dropped, stamped
    assert not any(p.exists() for p in cached) and (cache / STAMP_NAME).exists()
    fill()
    assert not invalidate_stale_cache(sources, cache)  # nothing changed: kept
    assert all(p.exists() for p in cached)
    (sources / "integrators.py").write_text("A = 3\n")  # a module stepping.advance inlines
    assert invalidate_stale_cache(sources, cache)
    assert not any(p.exists() for p in cached)


#: Where the exact references may be imported: the references themselves and the offline plots'
#: "error against the closed form" (tests and benchmarks live outside the package).
REFERENCE_USERS = ("exact", "offline")


@pytest.mark.parametrize("path", sorted((REPO / "rigid_body_sim").rglob("*.py")),
                         ids=lambda p: str(p.relative_to(REPO / "rigid_body_sim")))
def test_production_never_imports_the_references(path: Path) -> None:
    """The oracle and the code it checks share nothing: no production module imports rigid_body_sim.exact."""
    if path.relative_to(REPO / "rigid_body_sim").parts[0] in REFERENCE_USERS:
        return
    used = [f"{path.name}:{line}: {'.'.join(target)}" for line, target in _relative_targets(path)
            if target[:2] == ("rigid_body_sim", "exact") or target[-1] == "closed_form"]
    assert not used, f"production code imports the exact references: {used}"


def test_the_reference_check_resolves_relative_imports() -> None:
    """The checker itself: ``from ..exact import closed_form`` inside a function is found."""
    fake = REPO / "rigid_body_sim" / "core" / "sample.py"
    found = [target for _line, target in _relative_targets_of_text(
        fake, "def f():\n    from ..exact import closed_form\n    from .kernels import layout\n")]
    assert found == [("rigid_body_sim", "exact"), ("rigid_body_sim", "core", "kernels")]
