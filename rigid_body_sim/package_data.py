"""The package's own data files: the default scene, shipped inside the package.

setup.py maps the package ``rigid_body_sim.config`` to the repository's ``config/``, so a wheel
and a colcon install put ``config/default_scene.yaml`` inside the installed package, where
:mod:`importlib.resources` finds it beside the imported ``rigid_body_sim``. Imported from a source
tree instead (an editable or ``setup.py develop`` install, colcon ``--symlink-install``, tests
run from a checkout or a workspace's ``src/``), the package has no ``config/`` inside it and the
data is the tree's ``config/`` beside it. Either way the data is that of the ``rigid_body_sim``
actually imported, never another copy an import hook knows of. setup.py also still installs
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
    package = Path(str(files(__package__)))  # the imported package, installed unzipped: a real directory
    data = package / "config"  # a wheel or a colcon install (package_dir applied)
    if not data.is_dir():  # a source tree: config/ beside the package
        data = package.parent / "config"
    path = data / DEFAULT_SCENE_FILE
    if not path.is_file():
        raise FileNotFoundError(f"default scene {path} is not installed with rigid_body_sim")
    return path
