"""Property-based tests (hypothesis) over random valid bodies, states and wrenches.

Bodies come from ``helpers.valid_bodies``: principal moments over six decades that satisfy the
triangle inequality (down to thin rods and flat plates), masses from 1e-6 to 1e6 kg, any
orientation and velocity; every fixed-step integrator is drawn. The properties:

* Δp = F t to round-off for a constant world force (every method integrates a constant);
* torque-free, |L| is kept to the method's guarantee: round-off for the splitting family
  (every stage an exact rotation), n (|ω|h)² for the Euler family (|L|² grows or shrinks by
  at most (|ω|h)² per step: L_new = L ± h L × ω), n (|ω|h)⁵ for rk4 (local error O(h⁵); the
  rates of a real body obey |ω̇| ≤ |ω|², since |I_j − I_k| ≤ I_i).

The other properties over the same bodies live with their subject: |q| = 1 after every step in
test_integrators.py, the same wrench in every frame in test_forces.py.

Reproducible: ``derandomize=True`` and no example database (``helpers.PROPERTY_SETTINGS``), so
CI runs the same examples every time.
"""

from __future__ import annotations

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from helpers import (
    EPS,
    FIXED_STEP_INTEGRATORS,
    PROPERTY_SETTINGS,
    SPLITTING_FAMILY,
    scene_of,
    valid_bodies,
    with_spin_step,
)
from rigid_body_sim.core import Simulator

ORDER_OF_L_ERROR = {"euler": 2, "semi_implicit_euler": 2, "implicit_gyroscopic": 2, "rk4": 5}  # per-step |L| error: (|ω|h)^p


@PROPERTY_SETTINGS
@given(spec=valid_bodies(), integrator=st.sampled_from(FIXED_STEP_INTEGRATORS), dt=st.sampled_from([1e-4, 1e-2, 0.5]),
       steps=st.integers(1, 40), accel=st.lists(st.floats(-100.0, 100.0), min_size=3, max_size=3))
def test_momentum_change_is_force_times_time(spec, integrator, dt, steps, accel) -> None:
    """A constant force F = m a at the COM, world axes: p(t) − p(0) = F t, to ~n ulps.

    (Named at the COM, ``b/world_aligned``: a force about a world point that is the COM at a
    step's start leaves the COM's path during the step, and its moment spins a needle up.)
    """
    body = with_spin_step(spec, 0.05, dt)
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


@PROPERTY_SETTINGS
@given(spec=valid_bodies(), integrator=st.sampled_from(FIXED_STEP_INTEGRATORS), steps=st.integers(1, 60),
       log_spin_step=st.floats(-3.0, np.log10(0.3)))
def test_angular_momentum_size_is_kept_to_the_method_s_guarantee(spec, integrator, steps, log_spin_step) -> None:
    """Torque-free: | |L| / |L0| − 1 | ≤ 64 n ε (splitting family) or n (|ω|h)^p (others),
    with n (|ω|h)² ≤ 0.01 for the Euler family (where the growth factor is still ~linear)."""
    spin_step = 10.0**log_spin_step
    p = ORDER_OF_L_ERROR.get(integrator)
    if p == 2:
        spin_step = min(spin_step, float(np.sqrt(0.01 / steps)))
    dt = 0.01
    sim = Simulator(scene_of({"b": with_spin_step(spec, spin_step, dt)}), integrator, dt)
    L0 = np.linalg.norm(sim.angular_momentum()[0])
    sim.step(steps)
    error = abs(np.linalg.norm(sim.angular_momentum()[0]) / L0 - 1.0)
    bound = 64 * steps * EPS if integrator in SPLITTING_FAMILY else steps * spin_step**p + 64 * steps * EPS
    assert error <= bound, (error, bound, spin_step)
