"""The physics core of rigid_body_sim: numpy and scipy only, never rclpy or a *_msgs package.

Public API: :func:`load_scene`, :class:`Scene`, :class:`SceneError`, :class:`Simulator`,
:class:`BodyState`, :class:`NonFiniteStateError`, :data:`INTEGRATORS`. Quaternions inside the
core are (w, x, y, z); everything this API hands out or takes is (x, y, z, w), as in ROS.
"""

from .integrators import INTEGRATORS
from .scene import Scene, SceneError, load_scene
from .simulator import BodyState, NonFiniteStateError, Simulator

__all__ = [
    "INTEGRATORS",
    "BodyState",
    "NonFiniteStateError",
    "Scene",
    "SceneError",
    "Simulator",
    "load_scene",
]
