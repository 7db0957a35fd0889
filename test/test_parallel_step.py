"""The step over bodies on several threads (kernels/parallel.py) gives the serial step's states to the bit.

The same code computes both sides (one body's step, whichever thread runs it), so the
comparison is bitwise. The parallel step's thresholds are lowered so that a small scene
(fast) runs in parallel, cut into many parts, over every model group: asymmetric boxes (the
integrator), spheres (isotropic), cylinders (symmetric), a translation-only and a planar body,
under gravity, with wrenches in body axes that defer the reduced bodies to the integrator in
some steps, and a scripted wrench (the step-by-step path).
"""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest

from rigid_body_sim.core import Simulator, load_scene
from rigid_body_sim.core.kernels import parallel

from helpers import COMPILED_INTEGRATORS

BODIES = 60
STEPS = 300


def _scene(scripted: bool):
    rng = np.random.default_rng(7)
    kinds = ({"box": [1.0, 0.6, 0.4]}, {"sphere": 0.2}, {"cylinder": [0.2, 1.0]})
    bodies = {}
    for i in range(BODIES):
        spec = {"mass": 1.0 + i % 3, "inertia": kinds[i % 3],
                "pose": {"position": rng.normal(size=3).tolist()},
                "twist": {"linear": rng.normal(size=3).tolist(), "angular": (3.0 * rng.normal(size=3)).tolist()}}
        if i == 10:
            spec["motion"] = "translation_only"
            spec["twist"]["angular"] = [0.0, 0.0, 0.0]
        if i == 11:
            spec["motion"] = "planar"
            spec["twist"] = {"linear": [0.4, -0.2, 0.0], "angular": [0.0, 0.0, 2.0]}
        bodies[f"b{i}"] = spec
    scene = {"gravity": [0.0, 0.0, -9.81], "bodies": bodies}
    if scripted:
        scene["wrenches"] = [{"body": "b4", "frame": "b4", "force": [0.0, 1.0, 0.0], "torque": [0.3, 0.0, 0.0],
                              "start": 0.0, "duration": 0.5}]
    return load_scene(scene)


def _states(integrator: str, threads: int, scripted: bool) -> np.ndarray:
    sim = Simulator(_scene(scripted), integrator=integrator, dt=0.004, threads=threads)
    for round_ in range(6):
        for b in range(round_, BODIES, 7):  # a different set of bodies under a wrench each round
            sim.apply_wrench(f"b{b}", force=[0.5, -1.0, 2.0], torque=[0.2, 0.1, -0.3], frame=f"b{b}")
        sim.step(STEPS // 6)
    return sim.state.rows().copy()


@pytest.fixture
def small_parallel_threshold(monkeypatch):
    """Parallel from 1 moving body, in parts of 7 bodies: a 60-body scene runs as it would at 1e5."""
    monkeypatch.setattr(parallel, "MIN_BODIES", 1)
    monkeypatch.setattr(parallel, "PART_BODIES", 7)


@pytest.mark.parametrize("scripted", [False, True], ids=["batched", "scripted"])
@pytest.mark.parametrize("integrator", COMPILED_INTEGRATORS)
def test_parallel_step_equals_the_serial_one_to_the_bit(integrator: str, scripted: bool,
                                                        small_parallel_threshold) -> None:
    if parallel.max_threads() < 2:  # a one-CPU machine: numba's pool has one thread; run it with two
        env = dict(os.environ, NUMBA_NUM_THREADS="2")
        child = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider",
                                f"{__file__}::test_parallel_step_equals_the_serial_one_to_the_bit"
                                f"[{integrator}-{'scripted' if scripted else 'batched'}]"],
                               env=env, capture_output=True, text=True, timeout=300)
        assert child.returncode == 0, child.stdout + child.stderr
        return
    serial = _states(integrator, 1, scripted)
    assert np.all(np.isfinite(serial))
    for threads in range(2, parallel.max_threads() + 1):
        np.testing.assert_array_equal(_states(integrator, threads, scripted), serial,
                                      err_msg=f"{integrator} on {threads} threads")


def test_thread_count_is_checked_and_takes_effect_at_once(small_parallel_threshold) -> None:
    sim = Simulator(_scene(False), integrator="rk4", dt=0.004)
    assert sim.threads == 0  # every core
    for bad in (-1, parallel.max_threads() + 1, 1.5, True, "2"):
        with pytest.raises(ValueError, match=r"threads: expected a whole number from 0 \(every core\) to"):
            sim.threads = bad
    assert sim.threads == 0
    sim.threads = 1
    sim.step(10)
    assert sim.threads == 1 and sim.step_count == 10


def test_a_blow_up_stops_the_parallel_step_where_it_stops_the_serial_one(small_parallel_threshold) -> None:
    """One body blows up (euler, fast spin): the same error, step count, failing body and kept state on 1 and 2+ threads."""
    from rigid_body_sim.core import NonFiniteStateError

    outcomes = []
    for threads in sorted({1, parallel.max_threads()}):
        scene = _scene(False)
        sim = Simulator(scene, integrator="euler", dt=0.004, threads=threads, energy_growth_limit=1.5)
        sim.set_body_state("b3", angular_velocity_world=[60.0, 90.0, 40.0])  # a box: the integrator steps it
        with pytest.raises(NonFiniteStateError) as info:
            sim.step(STEPS)
        outcomes.append((type(info.value), info.value.bodies, sim.step_count, sim.state.rows().copy()))
    first = outcomes[0]
    assert "b3" in first[1] and 0 < first[2] < STEPS
    for other in outcomes[1:]:
        assert other[:3] == first[:3]
        np.testing.assert_array_equal(other[3], first[3])


def test_cancel_stops_a_parallel_step_from_another_thread(small_parallel_threshold) -> None:
    """The parallel step holds no GIL and reads the cancel flag between steps, as the serial one does."""
    import threading

    sim = Simulator(_scene(False), integrator="rk4", dt=0.004, threads=parallel.max_threads())
    done: list[int] = []
    worker = threading.Thread(target=lambda: done.append(sim.step(10**9)))
    worker.start()
    worker.join(timeout=0.3)  # the compiled step runs meanwhile; this thread gets the GIL back
    sim.cancel()
    worker.join(timeout=30)
    assert not worker.is_alive()
    assert 0 < done[0] < 10**9 and sim.step_count == done[0]
