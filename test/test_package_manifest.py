"""package.xml and setup.py declare what the package imports, as rosdep keys and as pip names.

Every third-party module imported anywhere in rigid_body_sim/ must map to an ``exec_depend`` of
package.xml (a rosdep key) and to an ``install_requires`` name of setup.py, and every declared
dependency must be used. The rosdep keys were looked up in ros/rosdistro (rosdep/python.yaml
and kilted/distribution.yaml, commit 8468e88, August 2026; ``rosdep update`` cannot reach
the index from these machines); :data:`ROSDEP_KEYS` records where each one is defined. The one
import with no key of its own, ``mcap``, is named in docs/workspace.md with how it gets installed.
"""

from __future__ import annotations

import ast
import re
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "rigid_body_sim"

#: rosdep key → where rosdistro defines it (and what it installs on Debian/Ubuntu).
ROSDEP_KEYS = {
    "rclpy": "kilted/distribution.yaml (ROS package)",
    "rcl_interfaces": "kilted/distribution.yaml (ROS package)",
    "builtin_interfaces": "kilted/distribution.yaml (ROS package)",
    "geometry_msgs": "kilted/distribution.yaml (ROS package)",
    "nav_msgs": "kilted/distribution.yaml (ROS package)",
    "std_srvs": "kilted/distribution.yaml (ROS package)",
    "rosgraph_msgs": "kilted/distribution.yaml (ROS package)",
    "diagnostic_msgs": "kilted/distribution.yaml (ROS package)",
    "sensor_msgs": "kilted/distribution.yaml (ROS package, common_interfaces)",
    "visualization_msgs": "kilted/distribution.yaml (ROS package, common_interfaces)",
    "tf2_msgs": "kilted/distribution.yaml (ROS package, geometry2)",
    "ament_index_python": "kilted/distribution.yaml (ROS package)",
    "python3-numpy": "rosdep/python.yaml (apt python3-numpy)",
    "python3-scipy": "rosdep/python.yaml (apt python3-scipy)",
    "python3-yaml": "rosdep/python.yaml (apt python3-yaml)",
    "python3-numba": "rosdep/python.yaml (apt python3-numba; debian and ubuntu only)",
    "python3-matplotlib": "rosdep/python.yaml (apt python3-matplotlib)",
    "python3-tqdm": "rosdep/python.yaml (apt python3-tqdm)",
    "mcap-ros2-support": "rosdep/python.yaml (pip mcap-ros2-support, which requires mcap)",
    "python3-pytest": "rosdep/python.yaml (apt python3-pytest)",
    "python3-hypothesis": "rosdep/python.yaml (apt python3-hypothesis)",
}

#: Top-level module imported → (rosdep key, pip name). ``None``: no key of its own.
MODULES = {
    "rclpy": ("rclpy", None),
    "rcl_interfaces": ("rcl_interfaces", None),
    "builtin_interfaces": ("builtin_interfaces", None),
    "geometry_msgs": ("geometry_msgs", None),
    "nav_msgs": ("nav_msgs", None),
    "std_srvs": ("std_srvs", None),
    "rosgraph_msgs": ("rosgraph_msgs", None),
    "diagnostic_msgs": ("diagnostic_msgs", None),
    "sensor_msgs": ("sensor_msgs", None),
    "visualization_msgs": ("visualization_msgs", None),
    "tf2_msgs": ("tf2_msgs", None),
    "ament_index_python": ("ament_index_python", None),
    "numpy": ("python3-numpy", "numpy"),
    "scipy": ("python3-scipy", "scipy"),
    "yaml": ("python3-yaml", "pyyaml"),
    "numba": ("python3-numba", "numba"),
    "matplotlib": ("python3-matplotlib", "matplotlib"),
    "tqdm": ("python3-tqdm", "tqdm"),
    "mcap_ros2": ("mcap-ros2-support", "mcap-ros2-support"),
    "mcap": (None, "mcap"),
}

#: Modules of an optional extra of setup.py (``pip install -e .[view]``), imported only by the part of
#: the package that needs them (rigid_body_sim/view/, ``rigid-body-sim view``): no rosdep key, not in
#: install_requires; pins in requirements-view.txt. Module → extra.
OPTIONAL = {"viser": "view"}


def manifest_dependencies(kind: str) -> list[str]:
    return [element.text for element in ET.parse(ROOT / "package.xml").getroot().iter(kind)]


def imported_modules() -> set[str]:
    """Top-level names of every module imported in rigid_body_sim/ that is not ours or stdlib."""
    found = set()
    for path in PACKAGE.rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Import):
                found |= {alias.name.split(".")[0] for alias in node.names}
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                found.add(node.module.split(".")[0])
    return {name for name in found if name not in sys.stdlib_module_names and name not in ("rigid_body_sim", "__future__")}


def install_requires() -> list[str]:
    text = (ROOT / "setup.py").read_text()
    block = re.search(r"install_requires=\[(.*?)\]", text, re.S).group(1)
    return re.findall(r'"([^"]+)"', block)


def extras_require() -> dict[str, str]:
    text = (ROOT / "setup.py").read_text()
    block = re.search(r"extras_require=\{(.*?)\}", text, re.S).group(1)
    return dict(re.findall(r'"([^"]+)": \[([^\]]*)\]', block))


def test_every_import_is_declared_and_every_declaration_used():
    imports = imported_modules()
    extras = extras_require()
    for module, extra in OPTIONAL.items():
        assert module in imports and f'"{module}' in extras.get(extra, ""), (module, extra, extras)
        for path in PACKAGE.rglob("*.py"):
            if module in path.read_text(encoding="utf-8").split():
                assert "view" in path.relative_to(PACKAGE).parts, f"{module} imported outside rigid_body_sim/view/: {path}"
    imports -= set(OPTIONAL)
    assert imports <= set(MODULES), f"imported but not mapped to a rosdep key: {imports - set(MODULES)}"
    keys = {MODULES[m][0] for m in imports} - {None}
    assert set(manifest_dependencies("exec_depend")) == keys
    assert sorted(install_requires()) == sorted(MODULES[m][1] for m in imports if MODULES[m][1])


def test_every_key_was_looked_up():
    declared = manifest_dependencies("exec_depend") + manifest_dependencies("test_depend")
    assert set(declared) <= set(ROSDEP_KEYS), set(declared) - set(ROSDEP_KEYS)
    assert manifest_dependencies("test_depend") == ["python3-pytest", "python3-hypothesis"]


def test_workspace_page_names_the_import_without_a_key():
    section = (ROOT / "docs" / "workspace.md").read_text()
    for module, (key, pip_name) in MODULES.items():
        if key is None:
            assert f"`{pip_name}`" in section, module
    assert "rosdep install" in section and "colcon build" in section and "colcon test" in section
