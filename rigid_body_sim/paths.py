"""Where this package's shared files (scene and parameter YAML under ``config/``) are at run time.

The same code runs from three kinds of installation, and the config directory is in a
different place in each:

1. a source checkout, including ``pip install -e .`` and ``colcon build --symlink-install``:
   ``<repo>/config`` next to ``package.xml``, the live copy a developer edits;
2. a colcon/ament install (``AMENT_PREFIX_PATH`` set, e.g. after sourcing ``setup.bash``):
   ``<prefix>/share/rigid_body_sim/config``, found through ament_index;
3. a plain ``pip install .`` into a venv, without ament: setup.py's ``data_files`` land in
   ``<sys.prefix>/share/rigid_body_sim/config``.

They are tried in that order; the first directory that exists wins. Nothing here imports
ROS at module level, so the core and its tests can use it without rclpy.
"""

from __future__ import annotations

import sysconfig
import xml.etree.ElementTree as ET
from pathlib import Path

__all__ = ["PACKAGE_NAME", "DEFAULT_SCENE_FILE", "share_dir", "config_dir", "default_scene_path"]

PACKAGE_NAME = "rigid_body_sim"
DEFAULT_SCENE_FILE = "default_scene.yaml"


def _source_share_dir() -> Path | None:
    """Return the repository root if this module runs from a source tree, else None."""
    root = Path(__file__).resolve().parent.parent
    manifest = root / "package.xml"
    if not manifest.is_file():
        return None
    try:
        name = ET.parse(manifest).getroot().findtext("name")
    except ET.ParseError:
        return None
    return root if name == PACKAGE_NAME else None


def _ament_share_dir() -> Path | None:
    """Return the ament share directory, or None without ament_index or an ament prefix."""
    try:
        from ament_index_python.packages import (
            PackageNotFoundError,
            get_package_share_directory,
        )
    except ImportError:
        return None
    try:
        return Path(get_package_share_directory(PACKAGE_NAME))
    except (PackageNotFoundError, OSError):  # OSError: AMENT_PREFIX_PATH unset or empty
        return None


def _prefix_share_dir() -> Path:
    """Return ``<prefix>/share/rigid_body_sim`` of the running interpreter's data scheme."""
    return Path(sysconfig.get_path("data")) / "share" / PACKAGE_NAME


def _candidate_share_dirs() -> list[Path]:
    found = [_source_share_dir(), _ament_share_dir(), _prefix_share_dir()]
    return [p for p in found if p is not None]


def share_dir() -> Path:
    """Return the directory holding ``package.xml`` and ``config/`` for this installation.

    Returns
    -------
    pathlib.Path
        The first existing of: the source tree, the ament share directory, and
        ``<sys.prefix>/share/rigid_body_sim``.

    Raises
    ------
    FileNotFoundError
        If none of them has a ``config`` directory; the message lists where it looked.
    """
    candidates = _candidate_share_dirs()
    for candidate in candidates:
        if (candidate / "config").is_dir():
            return candidate
    tried = ", ".join(str(c / "config") for c in candidates)
    raise FileNotFoundError(
        f"no config directory for {PACKAGE_NAME}: looked in {tried}. "
        "Install the package (pip install -e . or colcon build) or run from the repository."
    )


def config_dir() -> Path:
    """Return the directory of the packaged scene and parameter files (``config/``).

    Raises
    ------
    FileNotFoundError
        As :func:`share_dir`.
    """
    return share_dir() / "config"


def default_scene_path() -> Path:
    """Return the path of the default scene file, ``config/default_scene.yaml``.

    Raises
    ------
    FileNotFoundError
        If the config directory or the scene file in it is missing.
    """
    path = config_dir() / DEFAULT_SCENE_FILE
    if not path.is_file():
        raise FileNotFoundError(f"default scene {path} does not exist")
    return path
