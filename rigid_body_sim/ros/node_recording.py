"""The node's recording (``record_path``): one MCAP file at a time, opened before it is needed.

A new file is opened while a parameter change is prepared (never under the tick lock, so an
open that blocks or fails only refuses the change), swapped in with the change, and the one it
replaces is finished afterwards. A failed write (disk full...) ends the recording with an error
in the log; the simulation goes on.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Callable

from ..core import Simulator
from ..offline.recording import McapRecorder

__all__ = ["NodeRecording"]


class NodeRecording:
    """The current recorder, if any.

    Parameters
    ----------
    logger : rclpy logger
    world_frame, namespace, node_name : str
        Written into each recording (frame of poses, topic prefix, metadata).
    """

    def __init__(self, logger: Any, world_frame: str, namespace: str, node_name: str):
        self._logger = logger
        self._world_frame = world_frame
        self._namespace = namespace
        self._node_name = node_name
        self.recorder: McapRecorder | None = None

    def open(self, path: str, sim: Simulator, *, dt: float | None = None, integrator: str | None = None) -> McapRecorder:
        """A new recorder at ``path`` for ``sim`` (not yet the current one).

        Raises
        ------
        OSError
            If the file cannot be created.
        """
        source = Path(sim.scene.source)
        try:
            scene_text = source.read_text(encoding="utf-8") if source.is_file() else None
        except (OSError, UnicodeDecodeError):
            scene_text = None
        recorder = McapRecorder(
            path, world_frame=self._world_frame, namespace=self._namespace, scene_text=scene_text,
            metadata={"scene": str(sim.scene.source), "integrator": integrator or sim.integrator,
                      "dt": repr(sim.dt if dt is None else dt), "node": self._node_name})
        self._logger.info(f"recording to {path}")
        return recorder

    def replace(self, recorder: McapRecorder | None) -> McapRecorder | None:
        """Make ``recorder`` the current one (hold the node's lock); returns the one it replaced,
        to :meth:`finish` after the lock is released."""
        old, self.recorder = self.recorder, recorder
        return old

    def write(self, write: Callable[[McapRecorder], None]) -> None:
        """``write(recorder)`` if recording; a failed write ends the recording."""
        recorder = self.recorder
        if recorder is None:
            return
        try:
            write(recorder)
        except OSError as exc:
            self._logger.error(f"recording to {recorder.path} failed ({exc}); not recording")
            self.recorder = None
            self.finish(recorder)

    def finish(self, recorder: McapRecorder) -> None:
        """Close ``recorder``: its summary and index are written, so the file is complete."""
        try:
            recorder.close()
        except OSError as exc:
            self._logger.error(f"could not finish the recording {recorder.path} ({exc})")
        else:
            self._logger.info(f"recording finished: {recorder.path} ({recorder.message_count} messages)")
