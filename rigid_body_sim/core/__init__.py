"""The physics core of rigid_body_sim: numpy and scipy only, never rclpy or a *_msgs package.

Public API: :func:`load_scene`, :class:`Scene`, :class:`SceneError`, :class:`Simulator`,
:class:`BodyState`, :class:`NonFiniteStateError` (and its :class:`DivergenceError`),
:data:`INTEGRATORS`, :class:`ScriptedWrench`, :func:`describe_scene`. Quaternions inside the
core are (w, x, y, z); everything this API hands out or takes is (x, y, z, w), as in ROS.

The scene loader is imported at once; the simulator, integrators and describe (numba, scipy)
on first use of their names (PEP 562), so that checking a scene file (``rigid-body-sim
check``) does not load the compiled kernels.
"""

from typing import TYPE_CHECKING, Any

from .scene import Scene, SceneError, ScriptedWrench, load_scene

if TYPE_CHECKING:
    from .describe import body_model_kind, describe_scene
    from .integrators import INTEGRATORS
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

_LAZY = {
    "body_model_kind": "describe", "describe_scene": "describe", "INTEGRATORS": "integrators",
    "BodyState": "simulator", "DivergenceError": "simulator", "NonFiniteStateError": "simulator", "Simulator": "simulator",
}


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        from importlib import import_module

        value = getattr(import_module(f".{_LAZY[name]}", __name__), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
