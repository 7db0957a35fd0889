"""The node's services (relative to the node's name):

``~/reset`` (std_srvs/Trigger)
    Back to the scene's initial state at t = 0; held wrenches and pending impulses dropped.
``~/set_paused`` (std_srvs/SetBool)
    Sets the ``paused`` parameter (through the parameter machinery, so it is validated and
    announced on /parameter_events like any other change).
``~/step`` (std_srvs/Trigger)
    Exactly one tick while paused; refused with a reason while running.

Each handler is a few lines over a method of the node's :class:`~rigid_body_sim.ros.session.SimSession`,
which does the work under its lock; a tick (or another request) that keeps the simulator longer
than ``BUSY_WAIT_S`` (session.py) makes ``~/reset`` and ``~/step`` refuse, saying which and for
how long, rather than wait.
"""

from __future__ import annotations

from rclpy.node import Node
from rclpy.parameter import Parameter
from std_srvs.srv import SetBool, Trigger

from .session import SimSession

__all__ = ["create_services"]


def create_services(node: Node, session: SimSession) -> list:
    """Create the services on ``node``, served by ``session`` (``~/set_paused`` by ``node``'s parameters); returns them."""

    def on_reset(_request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        response.success, response.message = session.reset()
        return response

    def on_set_paused(request: SetBool.Request, response: SetBool.Response) -> SetBool.Response:
        result = node.set_parameters([Parameter("paused", Parameter.Type.BOOL, bool(request.data))])[0]
        response.success = result.successful
        response.message = ("paused" if request.data else "running") if result.successful else result.reason
        return response

    def on_step(_request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        response.success, response.message = session.step_paused()
        return response

    return [
        node.create_service(Trigger, "~/reset", on_reset),
        node.create_service(SetBool, "~/set_paused", on_set_paused),
        node.create_service(Trigger, "~/step", on_step),
    ]
