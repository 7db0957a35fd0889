"""The node's robot-stack services (simulation_interfaces' StepSimulation, SpawnEntity and
DeleteEntity, with a standard type), relative to the node's name.

simulation_interfaces is not on PyPI and custom interfaces cannot be built here, so all three
use ``rcl_interfaces/srv/SetParameters``: its request is a list of named, typed values
(``rcl_interfaces/Parameter``) and its response one ``SetParametersResult`` (``successful``,
``reason``) per value, which is exactly "a typed request answered with success and a reason".
A request is handled whole: every result carries the same outcome.

``~/step_ticks``
    One INTEGER value named ``ticks``: exactly that many ticks while paused (1 to
    ``MAX_STEP_TICKS``), answered when done with the sim time reached; refused with a reason
    while running. The ticks run in a worker thread while the callback (a coroutine) awaits them,
    so the executor stays free: parameters, /diagnostics and the other services answer meanwhile
    (a request that needs the simulator is refused as busy, naming ``~/step_ticks``).
``~/spawn``
    One STRING value per new body: the name is the body's name, the value its definition in a
    scene file's YAML form (what goes under ``bodies.<name>``). The bodies appear with their
    topics; sim time goes on.
``~/delete``
    One value per body to delete, named by the body (the value is not used). Its topics go.

The work is done by the node's :class:`~rigid_body_sim.ros.session.SimSession` (``step_ticks``,
``edit``), under its lock.
"""

from __future__ import annotations

import threading
from typing import Callable, TypeVar

from rcl_interfaces.msg import ParameterType, SetParametersResult
from rcl_interfaces.srv import SetParameters
from rclpy.node import Node
from rclpy.task import Future

from .session import SimSession

__all__ = ["create_robot_services"]

_TYPE_NAMES = {ParameterType.PARAMETER_NOT_SET: "not set", ParameterType.PARAMETER_BOOL: "bool",
               ParameterType.PARAMETER_INTEGER: "integer", ParameterType.PARAMETER_DOUBLE: "double",
               ParameterType.PARAMETER_STRING: "string"}


def _answer(request: SetParameters.Request, response: SetParameters.Response, success: bool,
            reason: str) -> SetParameters.Response:
    count = max(1, len(request.parameters))
    response.results = [SetParametersResult(successful=success, reason=reason) for _ in range(count)]
    return response


T = TypeVar("T")


async def _in_worker_thread(node: Node, work: Callable[[], T], name: str) -> T:
    """``work()`` in a daemon thread, awaited: the executor serves other callbacks meanwhile.

    The future belongs to the node's executor and has a done callback, so completing it from the
    thread schedules that callback on the executor, which wakes it to resume the awaiting task.
    """
    executor = node.executor
    future: Future = executor.create_future() if executor is not None else Future()
    future.add_done_callback(lambda _done: None)

    def run() -> None:
        try:
            result = work()
        except Exception as exc:  # noqa: BLE001  (raised again in the awaiting callback)
            future.set_exception(exc)
        else:
            future.set_result(result)

    threading.Thread(target=run, name=name, daemon=True).start()
    return await future


def _type_name(value_type: int) -> str:
    return _TYPE_NAMES.get(value_type, f"type {value_type}")


def _names(request: SetParameters.Request, what: str) -> str | None:
    """Why the request's names are not usable (none, or repeated), or None."""
    names = [p.name for p in request.parameters]
    if not names:
        return f"refused: the request names no {what}; expected one parameter per {what}"
    repeated = sorted({n for n in names if names.count(n) > 1})
    if repeated:
        return f"refused: {repeated} named more than once"
    return None


def create_robot_services(node: Node, session: SimSession) -> list:
    """Create ``~/step_ticks``, ``~/spawn`` and ``~/delete`` on ``node``, served by ``session``; returns them."""

    async def on_step_ticks(request: SetParameters.Request,
                            response: SetParameters.Response) -> SetParameters.Response:
        params = list(request.parameters)
        if len(params) != 1 or params[0].name != "ticks" or params[0].value.type != ParameterType.PARAMETER_INTEGER:
            got = [(p.name, _type_name(p.value.type)) for p in params]
            return _answer(request, response, False,
                           f"refused: expected one integer parameter named 'ticks', got {got}")
        ticks = int(params[0].value.integer_value)
        outcome = await _in_worker_thread(node, lambda: session.step_ticks(ticks), "step_ticks")
        return _answer(request, response, *outcome)

    def on_spawn(request: SetParameters.Request, response: SetParameters.Response) -> SetParameters.Response:
        problem = _names(request, "body")
        if problem is None:
            wrong = [(p.name, _type_name(p.value.type)) for p in request.parameters
                     if p.value.type != ParameterType.PARAMETER_STRING]
            if wrong:
                problem = (f"refused: {wrong}: expected a string value per body, its definition in the scene "
                           "file's YAML form (mass, inertia, pose, ...)")
        if problem is not None:
            return _answer(request, response, False, problem)
        spawn = {p.name: p.value.string_value for p in request.parameters}
        return _answer(request, response, *session.edit(spawn, []))

    def on_delete(request: SetParameters.Request, response: SetParameters.Response) -> SetParameters.Response:
        problem = _names(request, "body")
        if problem is not None:
            return _answer(request, response, False, problem)
        return _answer(request, response, *session.edit({}, [p.name for p in request.parameters]))

    return [
        node.create_service(SetParameters, "~/step_ticks", on_step_ticks),
        node.create_service(SetParameters, "~/spawn", on_spawn),
        node.create_service(SetParameters, "~/delete", on_delete),
    ]
