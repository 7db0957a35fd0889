"""The package's own data files: the default scene, shipped inside the package.

``config/default_scene.yaml`` is package data of ``rigid_body_sim.config`` (setup.py maps that
package to the repository's ``config/``), so :mod:`importlib.resources` finds it in an editable
install, a wheel and a colcon install alike; a ``setup.py develop`` install (colcon
``--symlink-install``), which does not apply that mapping, reads ``config/`` beside the package. setup.py also still installs
``config/`` to ``share/rigid_body_sim/config`` for ROS users (``ros2 launch``, params files).
"""

from __future__ import annotations

from importlib.resources import files
from pathlib import Path

__all__ = ["DEFAULT_SCENE_FILE", "config_dir", "default_scene_path"]

DEFAULT_SCENE_FILE = "default_scene.yaml"


def config_dir() -> Path:
    """The directory holding the packaged scenes (``config/default_scene.yaml``...)."""
    return default_scene_path().parent


def default_scene_path() -> Path:
    """The path of the default scene file, ``config/default_scene.yaml``.

    Raises
    ------
    FileNotFoundError
        If the installation lacks it.
    """
    try:
        data = Path(str(files("rigid_body_sim.config")))  # installed unzipped: a real directory
    except ModuleNotFoundError:  # `setup.py develop` (colcon --symlink-install) ignores package_dir: the source tree
        data = Path(__file__).resolve().parent.parent / "config"
    path = data / DEFAULT_SCENE_FILE
    if not path.is_file():
        raise FileNotFoundError(f"default scene {path} is not installed with rigid_body_sim")
    return path
