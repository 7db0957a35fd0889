"""Where a node tick's time goes: cProfile of ``advance_one_tick`` with N bodies, in-process.

The node is built on a private Context and domain (no executor: the timer never fires), and
``advance_one_tick`` (step + publish pose, twist per body and /clock) is called in a loop.
"""

from __future__ import annotations

import cProfile
import io
import pstats
import tempfile
import time
from contextlib import contextmanager
from pathlib import Path

from ..node_batch import write_scene

#: A domain of its own (node_batch.py uses 78).
DOMAIN_ID = 77


@contextmanager
def _node_in_process(bodies: int, rate_hz: float, domain_offset: int):
    """A RigidBodySimNode with ``bodies`` boxes on a private Context and domain; shut down after."""
    import rclpy
    from rclpy.context import Context
    from rclpy.parameter import Parameter

    from rigid_body_sim.ros.node import RigidBodySimNode

    scene = write_scene(Path(tempfile.mkdtemp(prefix="rbs_prof_")), bodies)
    context = Context()
    rclpy.init(context=context, domain_id=DOMAIN_ID + domain_offset)
    try:
        node = RigidBodySimNode(context=context, parameter_overrides=[
            Parameter("scene", value=str(scene)), Parameter("status_period", value=0.0),
            Parameter("rate_hz", value=float(rate_hz))])
        try:
            yield node
        finally:
            node.destroy_node()
    finally:
        rclpy.try_shutdown(context=context)


def profile(bodies: int = 100, ticks: int = 200, top: int = 20) -> str:
    with _node_in_process(bodies, 1.0, 1) as node:
        node.advance_one_tick()
        t0 = time.perf_counter()
        for _ in range(20):
            node.advance_one_tick()
        plain_ms = 1e3 * (time.perf_counter() - t0) / 20
        profiler = cProfile.Profile()
        profiler.enable()
        for _ in range(ticks):
            node.advance_one_tick()
        profiler.disable()
    out = io.StringIO()
    out.write(f"advance_one_tick with {bodies} bodies: {plain_ms:.3g} ms per tick without the profiler\n")
    stats = pstats.Stats(profiler, stream=out)
    stats.sort_stats("cumulative").print_stats(top)
    stats.sort_stats("tottime").print_stats(top)
    return out.getvalue()


def profile_spin(bodies: int = 100, rate_hz: float = 100.0, seconds: float = 4.0, top: int = 22) -> str:
    """cProfile of the node spinning in-process (its own executor, no subscribers) for ``seconds``.

    This is the executor-timer mode (the in-process default, and the harness's); the
    ``rigid_body_sim_node`` executable ticks from its own thread instead (``tick_thread=True``),
    which cProfile, attached to this thread only, would not see.
    """
    from rclpy.executors import SingleThreadedExecutor

    with _node_in_process(bodies, rate_hz, 2) as node:
        executor = SingleThreadedExecutor(context=node.context)
        executor.add_node(node)
        profiler = cProfile.Profile()
        t0, s0 = time.monotonic(), node.simulator.step_count
        profiler.enable()
        while time.monotonic() - t0 < seconds:
            executor.spin_once(timeout_sec=0.1)
        profiler.disable()
        rate = (node.simulator.step_count - s0) / seconds
        executor.shutdown()
    out = io.StringIO()
    out.write(f"{bodies} bodies at rate_hz {rate_hz}, in-process, no subscribers: {rate:.1f} ticks/s under cProfile\n")
    pstats.Stats(profiler, stream=out).sort_stats("cumulative").print_stats(top)
    return out.getvalue()

