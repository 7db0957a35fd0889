"""The physics core of rigid_body_sim: numpy and scipy only, never rclpy or a *_msgs package.

Public API: :func:`load_scene`, :class:`Scene`, :class:`SceneError`, :class:`Simulator`,
:class:`BodyState`, :class:`NonFiniteStateError` (and its :class:`DivergenceError`),
:data:`INTEGRATORS`, :class:`ScriptedWrench`, :func:`describe_scene`. Quaternions inside the
core are (w, x, y, z); everything this API hands out or takes is (x, y, z, w), as in ROS.
"""

from .describe import body_model_kind, describe_scene
from .integrators import INTEGRATORS
from .scene import Scene, SceneError, ScriptedWrench, load_scene
from .simulator import BodyState, DivergenceError, NonFiniteStateError, Simulator

__all__ = [
    "INTEGRATORS",
    "BodyState",
    "DivergenceError",
    "NonFiniteStateError",
    "Scene",
    "SceneError",
    "ScriptedWrench",
    "Simulator",
    "body_model_kind",
    "describe_scene",
    "load_scene",
]
