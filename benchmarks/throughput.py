"""Throughput: body-steps per second against the number of bodies, and the one-body wrench step.

For each N, a scene of N identical tumbling boxes (no gravity) is stepped with ``sim.step(1)``
in a loop for at least ``min_seconds`` and at least 3 steps; body-steps/s = N·steps / wall
time. MuJoCo: N free bodies (contact and gravity disabled), ``mj_step`` in a loop; one model per N,
its ``opt.integrator`` switched between measurements; ``implicit`` (dense) skipped above 1e3
bodies. The
systems are interleaved at each N (ours for every integrator, then MuJoCo's) and each point
is the median of ``repeats`` measurements.

"One body, one wrench at a point per step" is ``apply_force_at_point(...)`` + ``step(1)``
against ``mj_applyFT(...)`` (into ``qfrc_applied``, zeroed first) + ``mj_step``.
"""

from __future__ import annotations

import statistics
import time

import numpy as np

from rigid_body_sim.core import INTEGRATORS, Simulator, load_scene

from . import mujoco_models as mjm

DT = 1e-3                                    # s
ANGULAR_VELOCITY = (0.3, 1.0, 0.2)           # rad/s, every body's initial spin
#: The one-body wrench benchmark restarts from the initial state every this many calls.
RESET_EVERY = 2000
#: MuJoCo refuses models with 65534 or more bodies ("number of bodies plus flexes must be less
#: than 65534"): it has no point at N = 1e5.
MUJOCO_MAX_BODIES = 65533
INERTIA_BOX = np.array([0.0866666667, 0.1933333333, 0.2266666667])  # kg·m², 2 kg 1.0 × 0.6 × 0.4 m box


def _scene(count: int):
    bodies = {f"b{i}": {"mass": 2.0, "inertia": {"box": [1.0, 0.6, 0.4]},
                        "pose": {"position": [10.0 * i, 0.0, 0.0], "orientation": [0, 0, 0, 1]},
                        "twist": {"linear": [0.0, 0.0, 0.0], "angular": list(ANGULAR_VELOCITY)}}
              for i in range(count)}
    return load_scene({"bodies": bodies})


def _timed(step, min_seconds: float) -> tuple[int, float]:
    """Call ``step()`` until min_seconds have passed and ≥ 3 calls; (calls, seconds)."""
    step()  # warm-up (first-call allocations)
    calls, t0 = 0, time.perf_counter()
    while True:
        step()
        calls += 1
        elapsed = time.perf_counter() - t0
        if elapsed >= min_seconds and calls >= 3:
            return calls, elapsed


def bodies_sweep(counts: list[int], min_seconds: float, repeats: int, log=print) -> list[dict]:
    rows = []
    for n in counts:
        scene = _scene(n)
        mj = None
        if mjm.available() and n < MUJOCO_MAX_BODIES:
            mj = mjm.make(n, INERTIA_BOX, 2.0, DT, "Euler")  # compiled once (slow for 1e4 bodies)
            mj[1].qvel.reshape(n, 6)[:, 3:] = ANGULAR_VELOCITY
        samples: dict[tuple[str, str], list[float]] = {}
        for _ in range(repeats):  # interleave systems within each repeat
            for name in INTEGRATORS:
                if name == "reference" and n > 1000:
                    continue  # solve_ivp over 6e4+ states per step: minutes per point
                sim = Simulator(scene, integrator=name, dt=DT)
                calls, sec = _timed(lambda: sim.step(1), min_seconds)
                samples.setdefault(("rigid_body_sim", name), []).append(n * calls / sec)
            if mj:
                m, d = mj
                for name, member in mjm.MJ_INTEGRATORS.items():
                    if name == "implicit" and n > 1000:
                        continue  # dense implicit: O(nv²) memory and seconds per step at 6e4 dofs
                    m.opt.integrator = getattr(mjm.mujoco.mjtIntegrator, member)
                    step = mjm.mujoco.mj_step
                    calls, sec = _timed(lambda: step(m, d), min_seconds)
                    samples.setdefault(("mujoco", name), []).append(n * calls / sec)
        for (system, name), values in samples.items():
            rows.append({"system": system, "integrator": name, "bodies": n,
                         "body_steps_per_s": statistics.median(values), "repeats": len(values)})
        log(f"  throughput N={n} done")
    return rows


def wrench_step(min_seconds: float, repeats: int) -> list[dict]:
    """µs per (one force at a point + one step) for one body, every integrator and MuJoCo's."""
    scene = _scene(1)
    force, point = np.array([0.0, 10.0, 0.0]), np.array([0.5, 0.3, 0.0])
    samples: dict[tuple[str, str], list[float]] = {}
    mj = {}
    if mjm.available():
        for name in mjm.MJ_INTEGRATORS:
            mj[name] = mjm.make(1, INERTIA_BOX, 2.0, DT, name)
            mj[name][1].qvel[3:6] = ANGULAR_VELOCITY  # as ours (free joint: body axes, identity pose)
    for _ in range(repeats):
        for name in INTEGRATORS:
            sim = Simulator(scene, integrator=name, dt=DT)
            calls_since_reset = [0]

            def ours():
                # The body-fixed force spins the box up without bound: back to the start every
                # RESET_EVERY calls (both systems), before the explicit methods blow up.
                calls_since_reset[0] += 1
                if calls_since_reset[0] == RESET_EVERY:
                    calls_since_reset[0] = 0
                    sim.reset()
                sim.apply_force_at_point("b0", force, point, frame="b0")
                sim.step(1)
            calls, sec = _timed(ours, min_seconds)
            samples.setdefault(("rigid_body_sim", name), []).append(1e6 * sec / calls)
        for name, (m, d) in mj.items():
            mujoco = mjm.mujoco
            zero3 = np.zeros(3)

            mj_calls = [0]

            def theirs():
                mj_calls[0] += 1
                if mj_calls[0] == RESET_EVERY:
                    mj_calls[0] = 0
                    mujoco.mj_resetData(m, d)
                    d.qvel[3:6] = ANGULAR_VELOCITY
                # force at a world point of the body (d.xipos/xmat: kinematics of the last step's start)
                R = d.xmat[1].reshape(3, 3)
                d.qfrc_applied[:] = 0.0
                mujoco.mj_applyFT(m, d, R @ force, zero3, d.xipos[1] + R @ point, 1, d.qfrc_applied)
                mujoco.mj_step(m, d)
            calls, sec = _timed(theirs, min_seconds)
            samples.setdefault(("mujoco", name), []).append(1e6 * sec / calls)

            def bare():
                mujoco.mj_step(m, d)
            calls, sec = _timed(bare, min_seconds)
            samples.setdefault(("mujoco (mj_step only)", name), []).append(1e6 * sec / calls)
    return [{"system": s, "integrator": n, "us_per_step": statistics.median(v), "repeats": len(v)}
            for (s, n), v in samples.items()]
