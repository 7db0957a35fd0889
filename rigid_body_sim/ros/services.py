"""The node's services (relative to the node's name):

``~/reset`` (std_srvs/Trigger)
    Back to the scene's initial state at t = 0; held wrenches and pending impulses dropped.
``~/set_paused`` (std_srvs/SetBool)
    Sets the ``paused`` parameter (through the parameter machinery, so it is validated and
    announced on /parameter_events like any other change).
``~/step`` (std_srvs/Trigger)
    Exactly one tick while paused; refused with a reason while running.

Each handler is a few lines over a public method of the node, which does the work under its
lock; a tick that keeps the simulator longer than ``BUSY_WAIT_S`` (node.py) makes ``~/reset``
and ``~/step`` refuse with a reason rather than wait.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from rclpy.parameter import Parameter
from std_srvs.srv import SetBool, Trigger

if TYPE_CHECKING:
    from .node import RigidBodySimNode

__all__ = ["create_services"]


def create_services(node: "RigidBodySimNode") -> list:
    """Create the services on ``node``; returns them."""

    def on_reset(_request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        response.success, response.message = node.reset_simulation()
        return response

    def on_set_paused(request: SetBool.Request, response: SetBool.Response) -> SetBool.Response:
        result = node.set_parameters([Parameter("paused", Parameter.Type.BOOL, bool(request.data))])[0]
        response.success = result.successful
        response.message = ("paused" if request.data else "running") if result.successful else result.reason
        return response

    def on_step(_request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        response.success, response.message = node.step_paused()
        return response

    return [
        node.create_service(Trigger, "~/reset", on_reset),
        node.create_service(SetBool, "~/set_paused", on_set_paused),
        node.create_service(Trigger, "~/step", on_step),
    ]
