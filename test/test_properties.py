"""Property-based tests (hypothesis) over random valid bodies, states and wrenches.

Bodies have principal moments over six decades that satisfy the triangle inequality (down to
thin rods and flat plates), masses from 1e-6 to 1e6 kg, any orientation and velocity; every
fixed-step integrator is drawn. The properties:

* Δp = F t to round-off for a constant world force (every method integrates a constant);
* torque-free, |L| is kept to the method's guarantee: round-off for the splitting family
  (every stage an exact rotation), n (|ω|h)² for the Euler family (|L|² grows or shrinks by
  at most (|ω|h)² per step: L_new = L ± h L × ω), n (|ω|h)⁵ for rk4 (local error O(h⁵); the
  rates of a real body obey |ω̇| ≤ |ω|², since |I_j − I_k| ≤ I_i);
* |q| = 1 to round-off after every step (renormalising is part of each method);
* the same physical wrench named in the world, body, world_aligned and site frames moves a
  body identically.

Reproducible: ``derandomize=True`` and no example database, so CI runs the same examples
every time; example counts keep the module at ~20 s.
"""

from __future__ import annotations

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from helpers import EPS, FIXED_STEP_INTEGRATORS, scene_of
from rigid_body_sim.core import Simulator
from rigid_body_sim.core.quaternion import quat_to_matrix, quat_wxyz_from_xyzw, quat_xyzw_from_wxyz

SETTINGS = settings(max_examples=50, deadline=None, derandomize=True, database=None,
                    suppress_health_check=[HealthCheck.too_slow])
SPLITTING_FAMILY = ("splitting", "symmetric_splitting", "exact_rotor_splitting")
ORDER_OF_L_ERROR = {"euler": 2, "semi_implicit_euler": 2, "implicit_gyroscopic": 2, "rk4": 5}  # per-step |L| error: (|ω|h)^p


@st.composite
def bodies(draw) -> dict:
    """A valid body: moments over six decades satisfying the triangle inequality, any mass,
    orientation and velocity. Returned as a scene-file body plus its principal moments."""
    scale = 10.0 ** draw(st.floats(-3.0, 3.0))
    a = scale * 10.0 ** draw(st.floats(-6.0, 0.0))  # down to 1e-6 of the largest: rods and plates
    b = scale * 10.0 ** draw(st.floats(-6.0, 0.0))
    # the third between |a − b| and a + b (a degenerate plate at either end is still a body)
    c = abs(a - b) + draw(st.floats(1e-3, 1.0)) * (a + b - abs(a - b))
    moments = np.array([a, b, c])[list(draw(st.permutations([0, 1, 2])))]
    mass = 10.0 ** draw(st.floats(-6.0, 6.0))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    q = rng.normal(size=4)
    q /= np.linalg.norm(q)
    body = {
        "mass": mass,
        "inertia": {"principal": moments.tolist()},
        "pose": {"position": rng.normal(scale=10.0, size=3).tolist(), "orientation": quat_xyzw_from_wxyz(q).tolist()},
        "twist": {"linear": rng.normal(size=3).tolist(), "angular": rng.normal(size=3).tolist()},
    }
    return {"body": body, "moments": moments, "rng": rng}


def _with_spin_step(spec: dict, spin_step: float, dt: float) -> dict:
    """The body, its angular velocity rescaled to |ω| dt = spin_step."""
    body = dict(spec["body"])
    w = np.array(body["twist"]["angular"])
    body["twist"] = {"linear": body["twist"]["linear"], "angular": (w * spin_step / (np.linalg.norm(w) * dt)).tolist()}
    return body


@SETTINGS
@given(spec=bodies(), integrator=st.sampled_from(FIXED_STEP_INTEGRATORS), dt=st.sampled_from([1e-4, 1e-2, 0.5]),
       steps=st.integers(1, 40), accel=st.lists(st.floats(-100.0, 100.0), min_size=3, max_size=3))
def test_momentum_change_is_force_times_time(spec, integrator, dt, steps, accel) -> None:
    """A constant force F = m a at the COM, world axes: p(t) − p(0) = F t, to ~n ulps.

    (Named at the COM, ``b/world_aligned``: a force about a world point that is the COM at a
    step's start leaves the COM's path during the step, and its moment spins a needle up.)
    """
    body = _with_spin_step(spec, 0.05, dt)
    mass = body["mass"]
    sim = Simulator(scene_of({"b": body}), integrator, dt)
    force = mass * np.array(accel)
    p0 = sim.linear_momentum()[0]
    for _ in range(steps):
        sim.apply_wrench("b", force=force, frame="b/world_aligned")  # at the COM
        sim.step()
    expected = p0 + force * steps * dt
    scale = np.abs(p0).max() + np.abs(force).max() * steps * dt
    assert np.all(np.abs(sim.linear_momentum()[0] - expected) <= 16 * steps * EPS * scale)


@SETTINGS
@given(spec=bodies(), integrator=st.sampled_from(FIXED_STEP_INTEGRATORS), steps=st.integers(1, 60),
       log_spin_step=st.floats(-3.0, np.log10(0.3)))
def test_angular_momentum_size_is_kept_to_the_method_s_guarantee(spec, integrator, steps, log_spin_step) -> None:
    """Torque-free: | |L| / |L0| − 1 | ≤ 64 n ε (splitting family) or n (|ω|h)^p (others),
    with n (|ω|h)² ≤ 0.01 for the Euler family (where the growth factor is still ~linear)."""
    spin_step = 10.0**log_spin_step
    p = ORDER_OF_L_ERROR.get(integrator)
    if p == 2:
        spin_step = min(spin_step, float(np.sqrt(0.01 / steps)))
    dt = 0.01
    sim = Simulator(scene_of({"b": _with_spin_step(spec, spin_step, dt)}), integrator, dt)
    L0 = np.linalg.norm(sim.angular_momentum()[0])
    sim.step(steps)
    error = abs(np.linalg.norm(sim.angular_momentum()[0]) / L0 - 1.0)
    bound = 64 * steps * EPS if integrator in SPLITTING_FAMILY else steps * spin_step**p + 64 * steps * EPS
    assert error <= bound, (error, bound, spin_step)


@SETTINGS
@given(spec=bodies(), integrator=st.sampled_from(FIXED_STEP_INTEGRATORS), steps=st.integers(1, 30),
       spin_step=st.floats(1e-4, 4.0))
def test_quaternions_stay_unit(spec, integrator, steps, spin_step) -> None:
    """After every step, | |q| − 1 | ≤ 4 ε, internally and as reported, at any |ω|h that does
    not blow up (a blow-up is reported, and leaves the last good, unit q)."""
    from rigid_body_sim.core import NonFiniteStateError

    sim = Simulator(scene_of({"b": _with_spin_step(spec, spin_step, 0.01)}), integrator, 0.01)
    for _ in range(steps):
        try:
            sim.step()
        except NonFiniteStateError:
            break
        assert abs(np.linalg.norm(sim.state.q_WP[0]) - 1.0) <= 4 * EPS
        assert abs(np.linalg.norm(sim.orientations_xyzw()[0]) - 1.0) <= 4 * EPS


#: The same load named in frames that keep it the same inside a step (test_forces.FRAME_GROUPS):
#: a force and couple fixed in the body, and a force along a line fixed in space.
FRAME_GROUPS = {"body-fixed": ("body", "site_body_axes", "point_in_body_frame"),
                "line fixed in space": ("world", "point_in_world_frame")}
FRAMES = tuple(frame for group in FRAME_GROUPS.values() for frame in group)


@SETTINGS
@given(spec=bodies(), integrator=st.sampled_from(FIXED_STEP_INTEGRATORS), steps=st.integers(1, 8),
       force=st.lists(st.floats(-10.0, 10.0), min_size=3, max_size=3),
       couple=st.lists(st.floats(-1.0, 1.0), min_size=3, max_size=3))
def test_the_same_wrench_in_every_frame_gives_the_same_motion(spec, integrator, steps, force, couple) -> None:
    """Force F at a body-fixed point r_B plus a couple C, named in each frame of its group (converted by
    hand from the current state every step): every copy in a group moves identically, to round-off."""
    rng = spec["rng"]
    site_B = rng.normal(size=3)
    body = _with_spin_step(spec, 0.1, 0.01)
    body["sites"] = {"s": {"position": site_B.tolist()}}
    sim = Simulator(scene_of({f"by_{frame}": body for frame in FRAMES}), integrator, 0.01)
    # Sized so that every body stays in every method's envelope over the run (|ω̇| ≲ 10 rad/s²,
    # |a| ≲ 100 m/s²): outside it, explicit methods amplify any difference, round-off included.
    I_min, arm = spec["moments"].min(), np.linalg.norm(site_B)
    F_W = np.array(force) * min(body["mass"], I_min / arm)
    C_W = np.array(couple) * 10.0 * I_min
    for _ in range(steps):
        for frame in FRAMES:
            name = f"by_{frame}"
            state = sim.body_state(name)
            R_WB = quat_to_matrix(quat_wxyz_from_xyzw(state.orientation_xyzw))
            arm_W = R_WB @ site_B  # COM → point, world axes
            if frame == "world":  # about the world origin, world axes
                sim.apply_wrench(name, F_W, C_W + np.cross(state.position_world + arm_W, F_W), frame="world")
            elif frame == "point_in_world_frame":
                sim.apply_force_at_point(name, F_W, state.position_world + arm_W, frame="world")
                sim.apply_wrench(name, torque=C_W, frame="world")
            elif frame == "body":  # about the COM, body axes
                sim.apply_wrench(name, R_WB.T @ F_W, R_WB.T @ (C_W + np.cross(arm_W, F_W)), frame=name)
            elif frame == "point_in_body_frame":
                sim.apply_force_at_point(name, R_WB.T @ F_W, site_B, frame=name)
                sim.apply_wrench(name, torque=R_WB.T @ C_W, frame=name)
            else:  # about the point, body axes
                sim.apply_wrench(name, R_WB.T @ F_W, R_WB.T @ C_W, frame=f"{name}/s")
        sim.step()
    # Round-off of the inputs: each frame's numbers reach the same (F, τ about the COM) up to
    # ~ε of the largest term added, |p + r| |F| for the world origin, through a chain of a
    # few dozen roundings per step (rotations, cross products, resolve, kicks); a torque error
    # δτ moves ω by n h δτ / I_min and the orientation by n h that; a force error likewise via
    # m; and the orientation's own round-off turns ω by ~ε per step.
    t = steps * 0.01
    lever = np.abs(sim.positions_world()).max() + np.linalg.norm(site_B) + 1.0
    d_torque = 256 * EPS * (lever * np.linalg.norm(F_W) + np.linalg.norm(C_W))
    d_force = 256 * EPS * np.linalg.norm(F_W)
    d_w = t * d_torque / spec["moments"].min() + 64 * steps * EPS * np.abs(sim.angular_velocities_world()).max()
    d_v = t * d_force / body["mass"]
    bounds = {"positions_world": t * d_v, "orientations_xyzw": t * d_w,
              "linear_velocities_world": d_v, "angular_velocities_world": d_w}
    for group, frames in FRAME_GROUPS.items():
        rows = [FRAMES.index(frame) for frame in frames]
        for readout in (sim.positions_world, sim.orientations_xyzw, sim.linear_velocities_world,
                        sim.angular_velocities_world):
            values = readout()[rows]
            bound = 1e-12 * np.abs(values).max() + bounds[readout.__name__]
            assert np.abs(values - values[0]).max() <= bound, (group, readout.__name__, values, bound)
