"""Simulator.cancel(): a long step in one thread stops at a step boundary when another thread asks.

The compiled step releases the GIL, so the asking thread runs while the step does, and the
step reads the flag between steps. What it returns must be exact: the state after the steps
it reports (compared with a fresh run of that many steps, same code, so bitwise), and time and
step_count counting exactly those.
"""

from __future__ import annotations

import threading
import time

import numpy as np
import pytest

from rigid_body_sim.core import Simulator, load_scene

DT = 0.001


def _scene(count: int):
    rng = np.random.default_rng(0)
    bodies = {f"b{i}": {"mass": 1.0, "inertia": {"box": [1.0, 0.6, 0.4]},
                        "pose": {"position": [3.0 * i, 0.0, 0.0], "orientation": [0, 0, 0, 1]},
                        "twist": {"linear": [0.0, 0.0, 0.0], "angular": rng.normal(size=3).tolist()}}
              for i in range(count)}
    return load_scene({"bodies": bodies})


@pytest.mark.parametrize("integrator", ["rk4", "euler"])
def test_a_step_cancelled_from_another_thread_stops_at_a_step_boundary(integrator: str) -> None:
    scene = _scene(2000)
    sim = Simulator(scene, integrator=integrator, dt=DT, model_reduction=False)
    sim.step(1)
    requested = 2_000_000  # tens of seconds of CPU uncancelled
    result: dict[str, object] = {}
    started = threading.Event()

    def run() -> None:
        started.set()
        result["done"] = sim.step(requested)

    worker = threading.Thread(target=run)
    worker.start()
    assert started.wait(30)
    time.sleep(0.2)
    ticks = 0
    deadline = time.monotonic() + 0.05
    while time.monotonic() < deadline:  # this thread runs while the step does: the GIL is free
        ticks += 1
    sim.cancel()
    worker.join(30)
    assert not worker.is_alive(), "cancel() did not stop the step"
    assert ticks > 100
    done = result["done"]
    assert isinstance(done, int) and 0 < done < requested
    assert sim.step_count == 1 + done
    assert sim.time == (1 + done) * DT

    fresh = Simulator(scene, integrator=integrator, dt=DT, model_reduction=False)
    fresh.step(1)
    fresh.step(done)
    for name in ("p_WC_W", "q_WP", "v_WC_W", "w_WP_P"):
        np.testing.assert_array_equal(getattr(sim.state, name), getattr(fresh.state, name))

    assert sim.step(3) == 3, "the flag is cleared when the cancelled step returns"
    assert sim.step_count == 4 + done


@pytest.mark.parametrize("integrator", ["rk4", "reference"])
def test_a_cancel_before_the_step_makes_it_do_nothing(integrator: str) -> None:
    """Asked while no step runs, the next step returns at once (compiled or numpy/scipy integrator)."""
    sim = Simulator(_scene(3), integrator=integrator, dt=DT)
    before = sim.state.p_WC_W.copy(), sim.state.q_WP.copy()
    sim.cancel()
    assert sim.step(5) == 0
    assert sim.step_count == 0 and sim.time == 0.0
    np.testing.assert_array_equal(sim.state.p_WC_W, before[0])
    np.testing.assert_array_equal(sim.state.q_WP, before[1])
    assert sim.step(2) == 2
    assert sim.step_count == 2
