"""Which files a peer may make the node read (``scene``) or write (``record_path``).

Any peer on the ROS domain can call the node's ``set_parameters``, so a run-time change of
``scene`` or ``record_path`` is confined, before the file system is touched, to directories the
operator named at start-up (read-only parameters):

- ``scene_dirs``: a run-time ``scene`` must be a ``.yaml``/``.yml`` file inside one of them
  (default: the package's ``config/`` and the working directory);
- ``record_dirs``: a run-time ``record_path`` must be an ``.mcap`` file inside one of them
  (default: the working directory).

Paths are compared after resolving symlinks and ``..`` (:func:`os.path.realpath`), so a link in
an allowed directory that points out of it is refused too. A refusal names the parameter and
the directories, never what the file holds, and is the same whether or not a path outside
them exists. Start-up values come from the operator and are not confined.

Besides, wherever it comes from (start-up or a change), a recording never targets
(:class:`RecordTargets`) the running scene's file, the file being recorded, or an existing
file this node did not create, unless ``record_overwrite`` was set to true at start-up: a new
file is created with ``O_EXCL`` before the recorder opens it, so an existing file is never
truncated by accident.
"""

from __future__ import annotations

import os
from typing import Any, Iterable, Mapping

from ..offline.recording import check_record_path
from ..package_data import config_dir
from ..safe_open import create_new_file, same_file

__all__ = ["RecordTargetRefused", "RecordTargets", "change_refusal", "default_scene_dirs", "outside_reason",
           "SCENE_SUFFIXES", "RECORD_SUFFIX"]

#: What a run-time scene file's name must end with.
SCENE_SUFFIXES = (".yaml", ".yml")
#: What a run-time recording's name must end with.
RECORD_SUFFIX = ".mcap"


class RecordTargetRefused(OSError):
    """A recording may not be written to this path (the running scene, the file being recorded, or
    an existing file the node did not create); nothing was opened or changed."""


def default_scene_dirs() -> list[str]:
    """``scene_dirs`` by default: the package's ``config/`` and the working directory (``.``)."""
    return [str(config_dir()), "."]


def _resolved(path: str) -> str:
    return os.path.realpath(os.path.expanduser(path))


def _inside(path: str, directories: Iterable[str]) -> bool:
    target = _resolved(path)
    for directory in directories:
        root = _resolved(directory)
        if target.startswith(root.rstrip(os.sep) + os.sep):
            return True
    return False


def outside_reason(name: str, path: Any, directories: Iterable[str], dirs_parameter: str) -> str | None:
    """Why ``path`` may not be used for parameter ``name`` at run time, or None if it is inside one
    of ``directories``. Decided on the path's text alone (after resolving symlinks): the reason
    is the same whether or not the path exists."""
    directories = list(directories)
    allowed = f"the directories of {dirs_parameter} (read-only, set at start-up): {directories}"
    if not isinstance(path, str) or "\0" in path:
        return f"{name} rejected: not a path inside {allowed}"
    try:
        inside = _inside(path, directories)
    except (OSError, ValueError):
        inside = False
    if not inside:
        return f"{name} rejected: {path!r} is not inside {allowed}"
    return None


def change_refusal(values: Mapping[str, Any], settings: Mapping[str, Any], running: Any, recording: Any) -> str | None:
    """Why a run-time change of ``scene`` / ``record_path`` in ``values`` is refused, or None.

    Parameters
    ----------
    values : mapping
        The parameters of the request (name → value).
    settings : mapping
        The node's settings with the request's values (``scene``, ``scene_dirs``, ``record_dirs``).
    running : Simulator
        The running simulator (its scene's file may not be recorded to).
    recording : NodeRecording
        The node's recording (its current file may not be recorded to again).
    """
    if "scene" in values:
        scene = values["scene"]
        reason = outside_reason("scene", scene, settings["scene_dirs"], "scene_dirs")
        if reason is None and not str(scene).lower().endswith(SCENE_SUFFIXES):
            reason = f"scene rejected: {scene!r} is not a scene file (a run-time scene must end with .yaml or .yml)"
        if reason is not None:
            return reason
    path = values.get("record_path")
    if not path:
        return None
    reason = outside_reason("record_path", path, settings["record_dirs"], "record_dirs")
    if reason is not None:
        return reason
    scenes = {str(running.scene.source), str(settings["scene"])}  # the file, also once a spawn renamed the source
    if any(same_file(path, scene) for scene in scenes):
        return f"record_path rejected: {path!r} is the scene file; a recording never overwrites the scene"
    current = recording.recorder
    if current is not None and same_file(path, current.path):
        return (f"record_path rejected: {path!r} is the file being recorded now; choose another file "
                "(or set record_path:='' first to finish it)")
    if not str(path).lower().endswith(RECORD_SUFFIX):
        return (f"record_path rejected: {path!r} does not end with {RECORD_SUFFIX} (a run-time recording is "
                "an MCAP file; no other name, such as a shell start-up file, may be created)")
    return None


class RecordTargets:
    """The files a node's recordings may be written to, and the ones it created.

    Parameters
    ----------
    overwrite : bool
        ``record_overwrite``: an existing file the node did not create may be overwritten.
    """

    def __init__(self, overwrite: bool = False):
        self.overwrite = overwrite
        self._created: set[tuple[int, int]] = set()  # (st_dev, st_ino) of the files this node created

    def claim(self, path: str | os.PathLike[str], scene: str, current: Any) -> None:
        """Make ``path`` ready for a recording: create it (``O_EXCL``) if it does not exist, or
        accept it if this node created it or overwriting was allowed at start-up.

        Raises
        ------
        RecordTargetRefused
            If ``path`` is ``scene``'s file, the file ``current`` (a recorder or None) writes, or
            an existing file the node did not create (without ``record_overwrite``).
        OSError
            If it cannot be created (missing directory, permission...).
        """
        text = os.fspath(path)
        problem = check_record_path(text)  # its directory exists and is writable; not a directory, FIFO, device
        if problem is not None:
            raise RecordTargetRefused(problem)
        if same_file(text, scene):
            raise RecordTargetRefused(f"{text!r} is the scene file; a recording never overwrites the scene")
        if current is not None and same_file(text, current.path):
            raise RecordTargetRefused(f"{text!r} is the file being recorded now; choose another file")
        try:
            made = create_new_file(text)
        except FileExistsError:
            pass
        else:
            self._created.add((made.st_dev, made.st_ino))
            return
        if self.overwrite:
            return
        try:
            info = os.stat(text)
        except OSError:
            info = None
        if info is None or (info.st_dev, info.st_ino) not in self._created:
            raise RecordTargetRefused(
                f"{text!r} exists and this node did not create it; a recording never overwrites an existing file "
                "unless the node was started with record_overwrite:=true") from None

