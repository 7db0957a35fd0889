"""The stability suite: every integrator at the extremes, and the loud failure when one breaks.

What is swept, and what is asserted:

* |ω|h from 1e-3 to 4 on I = (1, 2, 3) and rods I = (r, 1, 1 + r/2), r = 1e-3, 1e-6: the
  envelope of docs/stability.md is re-measured at its edges with the same functions
  (rigid_body_sim.tools.envelope) — each documented limit holds and the grid point just above
  it fails — and, in the slow run, recomputed whole, with the 1e6-step runs.
* Inside the envelope the errors are within the bound; outside it, an integrator that blows
  up (explicit and semi-implicit Euler from |ω|h ≈ 1e-3; rk4 near |ω|h ≈ 3) makes the
  simulator raise (DivergenceError or NonFiniteStateError), never hand back a non-finite state.
* Inertia ratios down to 1e-6 (rods, flat strips), near-degenerate triangle-inequality bodies
  (I1 + I2 ≈ I3), dt from 1e-7 s to 1 s, masses from 1e-6 to 1e6 kg with matching forces,
  wrenches up to 1e12, spin exactly along each principal axis and just off the intermediate one.
* The two splittings built for fast spins: symmetric_splitting (exact on symmetric tops,
  error ∝ asymmetry) and exact_rotor_splitting (exact when torque-free); their second order
  with torques is measured with every other method's in test_order.py.

Tolerances come from the method (round-off ~ n·ε for exact rotations; the documented 1e-3
envelope; order × h), never from a previous run of the same code.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest

from helpers import EPS, FIXED_STEP_INTEGRATORS, NUMPY_STEPPED_INTEGRATORS, SPLITTING_FAMILY, loglog_slope, scene_of
from rigid_body_sim.core import DivergenceError, NonFiniteStateError, SceneError, Simulator, load_scene
from rigid_body_sim.exact import closed_form
from rigid_body_sim.core.free_rotor import exact_rotor, rotor_pairing, symmetric_split_rotor
from rigid_body_sim.core.quaternion import quat_angle_between, quat_wxyz_from_xyzw
from rigid_body_sim.tools import envelope

DOC = Path(__file__).resolve().parents[1] / "docs" / "stability.md"
EXPLODING = ("euler", "semi_implicit_euler")


def _documented() -> dict:
    return envelope.read_data(DOC)


def _run_or_raise(sim: Simulator, steps: int) -> NonFiniteStateError | None:
    """Step, stopping a body the way the node does when the simulator reports it."""
    failure = None
    target = sim.step_count + steps
    while sim.step_count < target:
        try:
            sim.step(target - sim.step_count)
        except NonFiniteStateError as err:
            failure = failure or err
            assert sim.state.finite_bodies().all(), "a failed step must leave the last good state"
            for body in err.bodies:
                sim.stop_body(body)
            if len(sim.stopped_bodies) == len(sim.body_names):
                break
    return failure


def _spinning(inertia, w_P, *, mass: float = 1.0, name: str = "b") -> dict:
    return {name: {"mass": mass, "inertia": {"principal": list(map(float, inertia))},
                   "twist": {"angular": list(map(float, w_P))}}}


# ----------------------------------------------------------------------------- the documented envelope


def test_the_document_covers_every_fixed_step_integrator() -> None:
    data = _documented()
    assert data["integrators"] == list(envelope.SWEPT_INTEGRATORS)
    assert set(envelope.SWEPT_INTEGRATORS) == set(FIXED_STEP_INTEGRATORS)
    assert data["bodies"] == {name: list(inertia) for name, inertia in envelope.BODIES.items()}
    assert set(data["long"]) == set(envelope.SWEPT_INTEGRATORS), "regenerate docs/stability.md without --no-long"


#: The numpy-stepped methods (the exact rotor: ms a step): 1e4 steps of them are a soak, run slow; the
#: default run keeps SHORT_STEPS of it. Its limits are the grid's end (it never fails there), so a
#: shorter run checks the same thing over fewer steps.
SHORT_STEPS = 1_000


def _envelope_cases() -> list:
    cases = []
    for name in envelope.SWEPT_INTEGRATORS:
        if name in NUMPY_STEPPED_INTEGRATORS:
            cases += [pytest.param(name, SHORT_STEPS, id=f"{name}-{SHORT_STEPS:.0e}".replace("+0", "")),
                      pytest.param(name, envelope.ENVELOPE_STEPS, marks=pytest.mark.slow, id=name)]
        else:
            cases.append(pytest.param(name, envelope.ENVELOPE_STEPS, id=name))
    return cases


@pytest.mark.parametrize(("integrator", "steps"), _envelope_cases())
def test_documented_envelope_holds_at_its_limit_and_fails_just_above(integrator: str, steps: int) -> None:
    """The envelope columns of docs/stability.md, re-measured at their edges with the same code.

    Each documented limit must keep the energy error below ENERGY_TOLERANCE over
    ENVELOPE_STEPS, and the grid point just above it must not: the table is right to the grid's
    resolution (a factor 2^(1/32)). The slow run recomputes the whole search.
    """
    limits = _documented()["envelope"][integrator]["limits"]
    if steps < envelope.ENVELOPE_STEPS:  # a failure documented over ENVELOPE_STEPS may not show in fewer
        assert all(limit["first_failure"] is None for limit in limits.values()), limits
    inertia, spin, expect = [], [], []
    for body, limit in limits.items():
        if limit["status"] != "below":
            inertia.append(envelope.BODIES[body])
            spin.append(limit["limit"])
            expect.append((body, limit["limit"], True))
        if limit["first_failure"] is not None:
            inertia.append(envelope.BODIES[body])
            spin.append(limit["first_failure"])
            expect.append((body, limit["first_failure"], False))
    run = envelope.torque_free_run(integrator, np.array(inertia), np.array(spin), steps,
                                   stop_error=envelope.ENERGY_TOLERANCE)
    for (body, spin_step, holds), error in zip(expect, run.energy_error):
        assert (error < envelope.ENERGY_TOLERANCE) == holds, (
            f"{integrator} on {body} at |ω|h = {spin_step:.4g}: energy error {error:.3g}, "
            f"documented to {'hold' if holds else 'fail'}"
        )


@pytest.mark.parametrize("steps", [SHORT_STEPS, pytest.param(envelope.ENVELOPE_STEPS, marks=pytest.mark.slow)])
def test_exact_rotor_targets_are_met_and_documented(steps: int) -> None:
    """exact_rotor_splitting: energy < 1e-3 over 1e4 steps at |ω|h = 4 for (1, 2, 3) and 0.5 for
    the rod r = 1e-6, |L| to 1e-10. The exact flow keeps both to round-off: ~n·ε, far below.
    Re-measured over the documented 1e4 steps in the slow run, over SHORT_STEPS by default."""
    if steps == envelope.ENVELOPE_STEPS:
        run = envelope.issue_targets()
    else:
        inertia = np.array([envelope.BODIES[body] for body, _ in envelope.TARGETS])
        run = envelope.torque_free_run(envelope.TARGET_INTEGRATOR, inertia, np.array([s for _, s in envelope.TARGETS]), steps)
    assert np.all(run.energy_error < 1e-10), run.energy_error
    assert np.all(run.momentum_error < envelope.TARGET_MOMENTUM_TOLERANCE), run.momentum_error
    documented = _documented()["targets"]
    assert np.all(np.array(documented["energy_error"]) < envelope.ENERGY_TOLERANCE)
    assert np.all(np.array(documented["momentum_error"]) < envelope.TARGET_MOMENTUM_TOLERANCE)


def test_documented_claims_about_the_known_failures() -> None:
    """The known failures the fast-spin splittings answer, as the table shows them."""
    limits = {name: {b: v["limit"] for b, v in d["limits"].items()} for name, d in _documented()["envelope"].items()}
    for name in EXPLODING:
        assert max(limits[name].values()) < 0.01  # any explicit ω update: drift at |ω|h ≈ 1e-3 already
    for name in ("exact_rotor_splitting", "implicit_gyroscopic"):  # exact flow; energy-exact midpoint rotor
        assert limits[name] == {b: 2.0**envelope.GRID_MAX_EXP for b in envelope.BODIES}
    assert limits["splitting"]["rod r = 1e-6"] < limits["splitting"]["I = (1, 2, 3)"]  # degrades for rods
    assert limits["symmetric_splitting"]["rod r = 1e-6"] > limits["splitting"]["rod r = 1e-6"]
    assert 0.1 < limits["rk4"]["I = (1, 2, 3)"] < 3.0


# ----------------------------------------------------------------------------- loud failure


@pytest.mark.parametrize("integrator", EXPLODING)
def test_explicit_eulers_blow_up_loudly_at_a_tenth(integrator: str) -> None:
    """|ω|h = 0.1 on (1, 2, 3): energy grows every step; within a few thousand steps the
    simulator stops with a DivergenceError naming the body, step, integrator and |ω|·dt."""
    w = 0.1 * envelope.SPIN_DIRECTION_P
    sim = Simulator(scene_of(_spinning((1.0, 2.0, 3.0), w, name="top")), integrator, 1.0)
    with pytest.raises(DivergenceError) as info:
        sim.step(5000)
    err = info.value
    assert isinstance(err, NonFiniteStateError)  # so the node's handler stops the body
    assert 100 < err.step_index == sim.step_count < 5000
    assert err.bodies == ("top",) and err.integrator == integrator and err.dt == 1.0
    spin = math.hypot(*sim.angular_velocities_body()[0])
    assert err.spin_step["top"] == pytest.approx(spin)
    assert err.kinetic_energy["top"] > err.limit * err.energy_bound["top"]
    assert err.energy_bound["top"] == pytest.approx(0.5 * 6.0 * 0.01 / 3.0)  # no input: the initial energy
    message = str(err)
    for part in (f"energy blow-up at step {err.step_index} with integrator {integrator!r}, dt = 1 s",
                 f"top (|w|·dt = {spin:.3g} rad)", "smaller dt", "more substeps", "another integrator"):
        assert part in message
    assert sim.state.finite_bodies().all()
    assert sim.kinetic_energy()[0] <= err.limit * err.energy_bound["top"]  # the last good step


@pytest.mark.parametrize("body", ["rod r = 1e-3", "rod r = 1e-6"])
def test_rk4_blows_up_loudly_near_three(body: str) -> None:
    """rk4's stability region ends at |λh| = 2√2 on the imaginary axis: a rod at |ω|h = 3
    (its spin about the rod axis drives the fast mode) explodes within a few hundred steps."""
    sim = Simulator(scene_of(_spinning(envelope.BODIES[body], 3.0 * envelope.SPIN_DIRECTION_P)), "rk4", 1.0)
    with pytest.raises(NonFiniteStateError) as info:
        sim.step(2000)
    assert info.value.step_index < 2000
    assert sim.state.finite_bodies().all()


SHAPES = {
    "I = (1, 2, 3)": (1.0, 2.0, 3.0),
    "rod r = 1e-6": (1e-6, 1.0, 1.0 + 0.5e-6),
    "flat strip r = 1e-6": (1e-6, 1.0, 1.0 + 1e-6),  # I3 = I1 + I2: a thin plate, triangle equality
    "near-degenerate": (1.0, 1.5, 2.5 * (1.0 - 1e-9)),  # I1 + I2 ≈ I3
    "disc": (1.0, 1.0, 2.0),
}
SPIN_STEPS = (1e-3, 0.01, 0.1, 0.5, 1.0, 2.0, 3.0, 4.0)
SWEEP_STEPS = 400


@pytest.fixture(scope="module")
def documented_limits() -> dict:
    return {name: {b: v["limit"] for b, v in d["limits"].items()} for name, d in _documented()["envelope"].items()}


@pytest.mark.parametrize("integrator", FIXED_STEP_INTEGRATORS)
def test_sweep_every_shape_and_spin_step_is_right_or_loud(integrator: str, documented_limits: dict) -> None:
    """Every shape × |ω|h in one scene, SWEEP_STEPS steps, stopping bodies as the node does.

    Afterwards every state is finite; every body inside its documented envelope ran through
    with an energy error below the envelope's tolerance, and |L| kept to round-off by the
    splitting family; a body the simulator stopped was outside the envelope.
    """
    bodies = {}
    for s, (shape, inertia) in enumerate(SHAPES.items()):
        for k, spin in enumerate(SPIN_STEPS):
            bodies.update(_spinning(inertia, spin * envelope.SPIN_DIRECTION_P, name=f"s{s}k{k}"))
    sim = Simulator(scene_of(bodies), integrator, 1.0)
    E0, L0 = sim.kinetic_energy(), np.linalg.norm(sim.angular_momentum(), axis=1)
    _run_or_raise(sim, SWEEP_STEPS)
    assert sim.state.finite_bodies().all()
    energy_error = np.abs(sim.kinetic_energy() / E0 - 1.0)
    momentum_error = np.abs(np.linalg.norm(sim.angular_momentum(), axis=1) / L0 - 1.0)
    stopped = set(sim.stopped_bodies)
    for s, shape in enumerate(SHAPES):
        limit = documented_limits[integrator].get(shape)
        for k, spin in enumerate(SPIN_STEPS):
            i = sim.body_names.index(f"s{s}k{k}")
            if limit is not None and spin <= limit:
                assert f"s{s}k{k}" not in stopped, (shape, spin)
                assert energy_error[i] < envelope.ENERGY_TOLERANCE, (shape, spin, energy_error[i])
            if integrator in SPLITTING_FAMILY and f"s{s}k{k}" not in stopped:
                assert momentum_error[i] < 64 * SWEEP_STEPS * EPS, (shape, spin, momentum_error[i])
            if integrator == "exact_rotor_splitting":
                assert f"s{s}k{k}" not in stopped
                assert energy_error[i] < 64 * SWEEP_STEPS * EPS, (shape, spin, energy_error[i])
    if integrator in EXPLODING:
        assert stopped, "explicit Euler at |ω|h up to 4 must have blown up somewhere"


def test_energy_growth_limit_comes_from_the_scene_and_is_validated() -> None:
    bodies = _spinning((1.0, 2.0, 3.0), 0.1 * envelope.SPIN_DIRECTION_P)
    assert load_scene({"bodies": bodies}).energy_growth_limit == 1e6
    scene = load_scene({"energy_growth_limit": 10.0, "bodies": bodies})
    assert scene.energy_growth_limit == 10.0
    strict, loose = Simulator(scene, "euler", 1.0), Simulator(load_scene({"bodies": bodies}), "euler", 1.0)
    assert strict.energy_growth_limit == 10.0
    with pytest.raises(DivergenceError, match=r"more than 10 × "):
        strict.step(5000)
    with pytest.raises(DivergenceError):
        loose.step(5000)
    assert strict.step_count < loose.step_count  # the tighter factor trips first
    for value, expected in ((1.0, "a number > 1"), (0.5, "a number > 1"), (-3, "a number > 1"),
                            ("big", "a number"), (float("nan"), "a finite number"), (True, "a number")):
        with pytest.raises(SceneError, match=re.escape(f"<dict>: energy_growth_limit: expected {expected} "
                                                       "(a factor on the kinetic energy), got")):
            load_scene({"energy_growth_limit": value, "bodies": bodies})
    with pytest.raises(ValueError, match=r"energy_growth_limit: expected a finite number > 1, got 1"):
        Simulator(scene, "rk4", 0.01, energy_growth_limit=1)


@pytest.mark.parametrize("integrator", FIXED_STEP_INTEGRATORS)
def test_work_done_by_inputs_never_trips_the_energy_check(integrator: str) -> None:
    """Bodies pushed from rest, falling, kicked by impulses or re-set: all energy explained."""
    scene = load_scene({
        "gravity": [0.0, 0.0, -9.81],
        "bodies": {
            "pushed": {"mass": 1e-6, "inertia": {"principal": [1e-12, 2e-12, 2.5e-12]}},
            "falling": {"mass": 1e6, "inertia": {"principal": [1e6, 2e6, 2.5e6]}},
            "kicked": {"mass": 2.0, "inertia": {"box": [1.0, 0.6, 0.4]}},
        },
    })
    sim = Simulator(scene, integrator, 1e-3)
    for k in range(300):
        sim.apply_wrench("pushed", force=[1e-3, 0.0, 0.0], torque=[0.0, 0.0, 1e-12], frame="pushed")
        if k % 50 == 0:
            sim.apply_impulse("kicked", linear=[0.0, 5.0, 0.0], angular=[0.0, 0.0, 0.5], frame="kicked")
        if k == 150:
            sim.set_body_state("kicked", linear_velocity_world=[100.0, 0.0, 0.0])
        sim.step()
    assert sim.step_count == 300 and not sim.stopped_bodies


# ----------------------------------------------------------------------------- dt, mass and wrench ranges


@pytest.mark.parametrize("integrator", FIXED_STEP_INTEGRATORS)
def test_only_spin_step_matters_from_dt_1e7_to_1s(integrator: str) -> None:
    """A free body at |ω|h = 0.05 with dt = 1e-7 … 1 s: the same relative energy and body-rate
    history (time rescales away), to round-off; and the translation p = p0 + v t."""
    errors, rates = [], []
    for dt in (1e-7, 1e-4, 1e-2, 1.0):
        w = (0.05 / dt) * envelope.SPIN_DIRECTION_P
        bodies = _spinning((1.0, 2.0, 3.0), w)
        bodies["b"]["twist"]["linear"] = [3.0, -1.0, 2.0]
        sim = Simulator(scene_of(bodies), integrator, dt)
        sim.step(200)
        w_end = sim.angular_velocities_body()[0]  # B = P here (principal moments given)
        errors.append(np.sum(np.array([1.0, 2.0, 3.0]) * w_end**2) / np.sum(np.array([1.0, 2.0, 3.0]) * w**2) - 1.0)
        rates.append(w_end * dt)
        np.testing.assert_allclose(sim.positions_world()[0], np.array([3.0, -1.0, 2.0]) * 200 * dt,
                                   rtol=200 * 4 * EPS)
    np.testing.assert_allclose(errors, errors[-1], rtol=1e-6, atol=1e3 * EPS)
    np.testing.assert_allclose(np.array(rates), np.tile(rates[-1], (4, 1)), rtol=0, atol=1e-12)


@pytest.mark.parametrize("integrator", FIXED_STEP_INTEGRATORS)
def test_masses_from_1e6_to_1e6_kg_with_forces_to_match(integrator: str) -> None:
    """m from 1e-6 to 1e6 kg, I ∝ m, F = m a and a torque about a principal axis ∝ I:
    Δ(m v) = F t and Δ(I ω) = τ t to round-off (every method integrates a constant exactly)."""
    masses = 10.0 ** np.arange(-6, 7, 2)
    acceleration = np.array([1.0, -2.0, 0.5])
    bodies = {f"m{i}": {"mass": float(m), "inertia": {"principal": [0.1 * m, 0.2 * m, 0.25 * m]},
                        "twist": {"linear": [0.3, 0.0, 0.0]}}
              for i, m in enumerate(masses)}
    sim = Simulator(scene_of(bodies), integrator, 1e-2)
    n = 250
    for _ in range(n):
        for i, m in enumerate(masses):
            sim.apply_wrench(f"m{i}", force=m * acceleration, torque=[0.0, 0.0, 0.25 * m * 2.0], frame=f"m{i}/world_aligned")
        sim.step()
    t = n * 1e-2
    momentum = sim.linear_momentum()
    expected = masses[:, None] * (np.array([0.3, 0.0, 0.0]) + acceleration * t)
    scale = np.abs(expected).max(axis=1, keepdims=True)  # kg·m/s, per body: 1e-6 … 1e6
    assert np.all(np.abs(momentum - expected) <= n * 8 * EPS * scale), (momentum - expected) / scale
    spin = sim.angular_velocities_world()
    np.testing.assert_allclose(spin[:, 2], 2.0 * t, rtol=n * 8 * EPS)
    np.testing.assert_array_equal(spin[:, :2], 0.0)


@pytest.mark.parametrize("integrator", FIXED_STEP_INTEGRATORS)
def test_wrenches_up_to_1e12(integrator: str) -> None:
    """A 1e12 N force and 1e12 N·m torque on a 1 kg, I = (1, 2, 3) body from rest, 200 steps.

    The momentum is the impulse to round-off for every method (Δp = F t). The torque, off
    the principal axes, soon spins the body at |ω|h ~ 1e8: the splitting family keeps
    L = τ t (kicks are exact and L_W is invariant under each rotation: to round-off for the
    principal-axis rotations, to ε·|ω|h ≈ 2e-8 per step for the exact flow, whose angles
    are ~1e8 rad); explicit methods blow up, loudly; implicit_gyroscopic's rotor keeps |L| and
    the energy exactly, so its |L| is the kicks' |τ| t to the rotor's turn of L in world axes
    (second order, and at |ω|h ~ 1e8 only bounded). Never a non-finite state.
    """
    scene = load_scene({"bodies": {"brick": {"mass": 1.0, "inertia": {"principal": [1.0, 2.0, 3.0]}}}})
    sim = Simulator(scene, integrator, 1e-3)
    force, torque = np.array([1e12, -3e11, 5e11]), np.array([4e11, 1e12, -2e11])
    n = 200
    failure = None
    for _ in range(n):
        sim.apply_wrench("brick", force=force, torque=torque, frame="world")
        try:
            sim.step()
        except NonFiniteStateError as err:
            failure = err
            break
    assert sim.state.finite_bodies().all()
    done = sim.step_count * 1e-3
    np.testing.assert_allclose(sim.linear_momentum()[0], force * done, rtol=64 * n * EPS)
    if integrator in SPLITTING_FAMILY:
        assert failure is None
        spin_step = math.hypot(*sim.angular_velocities_body()[0]) * 1e-3
        assert spin_step > 1e6  # far outside any envelope
        rtol = n * spin_step * EPS if integrator == "exact_rotor_splitting" else 64 * n * EPS
        np.testing.assert_allclose(sim.angular_momentum()[0], torque * done, rtol=rtol)
    elif integrator == "implicit_gyroscopic":
        assert failure is None
        assert np.linalg.norm(sim.angular_momentum()[0]) <= np.linalg.norm(torque) * done
    else:
        assert failure is not None, "an explicit method cannot survive |ω|h ~ 1e8"


# ----------------------------------------------------------------------------- principal axes


@pytest.mark.parametrize("integrator", FIXED_STEP_INTEGRATORS)
@pytest.mark.parametrize("axis", [0, 1, 2])
def test_spin_exactly_along_a_principal_axis_stays_there(integrator: str, axis: int) -> None:
    """ω along a principal axis (the intermediate one too, an unstable equilibrium): the
    gyroscopic term is exactly zero, so ω never leaves the axis, its size is kept, and the
    body turns about the axis by |ω| t, up to each method's phase error."""
    spin_step, n = 0.1, 300
    w = np.zeros(3)
    w[axis] = 7.0
    sim = Simulator(scene_of(_spinning((1.0, 2.0, 3.0), w)), integrator, spin_step / 7.0)
    sim.step(n)
    w_end = sim.angular_velocities_body()[0]
    off = [i for i in range(3) if i != axis]
    np.testing.assert_array_equal(w_end[off], 0.0)
    assert w_end[axis] == pytest.approx(7.0, rel=n * 4 * EPS)
    angle = spin_step * n
    exact = np.concatenate(([math.cos(angle / 2)], math.sin(angle / 2) * np.eye(3)[axis]))
    error = quat_angle_between(quat_wxyz_from_xyzw(sim.orientations_xyzw()[0]), exact)
    bound = {"euler": n * spin_step**3 / 12.0, "rk4": n * spin_step**5}.get(integrator, n * 64 * EPS * angle)
    assert error <= bound


FLIP_INERTIA, FLIP_RATE_B = (1.0, 2.0, 3.0), np.array([1e-3, 1.0, 1e-3])  # just off the intermediate axis


def test_exact_rotor_follows_the_flip_at_a_big_step() -> None:
    """ω = (1e-3, 1, 1e-3) on (1, 2, 3), the Dzhanibekov flip every 27.53 s, at |ω|h = 1:
    exact_rotor_splitting's body rate is the closed form's at every step (near the separatrix
    the elliptic functions keep ~1e-10; the flip is a sensitive test of the phase)."""
    sim = Simulator(scene_of(_spinning(FLIP_INERTIA, FLIP_RATE_B)), "exact_rotor_splitting", 1.0)
    rates = []
    for _ in range(75):
        sim.step()
        rates.append(sim.angular_velocities_body()[0])
    exact = closed_form.asymmetric_top_body_rates(np.array(FLIP_INERTIA), FLIP_RATE_B, np.arange(1.0, 76.0))
    assert exact[:, 1].min() < -0.99 < 0.99 < exact[:, 1].max()  # it flips over
    np.testing.assert_allclose(np.array(rates), exact, rtol=0, atol=1e-8)


def test_symmetric_splitting_flips_on_time() -> None:
    """The same flip with symmetric_splitting at |ω|h = 0.05, inside its envelope: the time
    between sign changes of ω2 within 1 % of 2K/ν (its phase error is ~(|ω|h)² ≈ 3e-3),
    crossings interpolated linearly between steps (as in test_integrators)."""
    h = 0.05
    sim = Simulator(scene_of(_spinning(FLIP_INERTIA, FLIP_RATE_B)), "symmetric_splitting", h)
    w2 = [FLIP_RATE_B[1]]
    for _ in range(round(75.0 / h)):
        sim.step()
        w2.append(sim.angular_velocities_body()[0, 1])
    w2 = np.array(w2)
    k = np.flatnonzero(np.sign(w2[1:]) != np.sign(w2[:-1]))
    crossings = (k + w2[k] / (w2[k] - w2[k + 1])) * h
    assert len(crossings) >= 3, crossings
    np.testing.assert_allclose(np.diff(crossings), closed_form.intermediate_axis_flip_period(FLIP_INERTIA, FLIP_RATE_B),
                               rtol=0.01)


# ----------------------------------------------------------------------------- the new integrators


def test_rotor_pairing_picks_the_median_and_its_closest_neighbour() -> None:
    t, s, k = rotor_pairing(np.array([[1.0, 2.0, 3.0], [1e-6, 1.0, 1.0 + 5e-7], [2.0, 1.0, 1.0 + 1e-3], [3.0, 2.0, 1.0]]))
    np.testing.assert_array_equal(t, [1, 1, 2, 1])  # the median moment
    np.testing.assert_array_equal(k, [2, 2, 1, 0])  # the other member of the closest pair
    np.testing.assert_array_equal(s, [0, 0, 0, 2])  # the symmetry axis of the top


def _random_symmetric_bodies(rng: np.random.Generator, n: int) -> np.ndarray:
    inertia = []
    for i in range(n):
        transverse, axial = rng.uniform(0.2, 2.0), rng.uniform(0.05, 2.0)
        axial = min(axial, 2 * transverse)  # a real body: I_s ≤ 2 I_t
        moments = np.array([transverse, transverse, axial])
        inertia.append(np.roll(moments, i))
    return np.array(inertia)


@pytest.mark.parametrize("rotor", [symmetric_split_rotor, exact_rotor])
def test_symmetric_tops_are_integrated_exactly(rotor) -> None:
    """Two equal moments: both rotors are the closed-form symmetric top, at any step."""
    rng = np.random.default_rng(50)
    inertia = _random_symmetric_bodies(rng, 12)
    w0 = rng.normal(scale=3.0, size=(12, 3))
    q0 = rng.normal(size=(12, 4))
    q0 /= np.linalg.norm(q0, axis=1, keepdims=True)
    h, n = 0.7, 40  # |ω|h up to ~10
    q, L = q0, inertia * w0
    for _ in range(n):
        q, L = rotor(inertia, q, L, h)
    for i in range(12):
        q_exact, w_exact = closed_form.symmetric_top(inertia[i], w0[i], q0[i], np.array([n * h]))
        scale = np.linalg.norm(w0[i]) * n * h
        assert quat_angle_between(q[i], q_exact[0]) < 64 * n * EPS * scale
        np.testing.assert_allclose(L[i] / inertia[i], w_exact[0], rtol=0, atol=64 * n * EPS * np.abs(w0[i]).max())


def test_exact_rotor_matches_the_elliptic_closed_form_in_one_big_step() -> None:
    """Random asymmetric bodies, one step of 5 s (|ω|h ~ 10): the orientation and rate of
    closed_form.asymmetric_top (which gets the precession angle by quadrature, an independent
    route), on the same quaternion sign branch."""
    rng = np.random.default_rng(51)
    inertia, w0, q0 = [], [], []
    while len(inertia) < 20:
        I = rng.uniform(0.2, 2.0, 3)
        if I.max() < I.sum() - I.max() and np.diff(np.sort(I)).min() > 0.05:
            inertia.append(I)
            w0.append(rng.normal(scale=2.0, size=3))
            q = rng.normal(size=4)
            q0.append(q / np.linalg.norm(q))
    inertia, w0, q0 = map(np.array, (inertia, w0, q0))
    q, L = exact_rotor(inertia, q0, inertia * w0, 5.0)
    for i in range(len(inertia)):
        q_exact, w_exact = closed_form.asymmetric_top(inertia[i], w0[i], q0[i], np.array([5.0]))
        np.testing.assert_allclose(q[i], q_exact[0], rtol=0, atol=1e-12)
        np.testing.assert_allclose(L[i] / inertia[i], w_exact[0], rtol=0, atol=1e-12)


@pytest.mark.parametrize("shape", ["rod r = 1e-6", "flat strip r = 1e-6", "near-degenerate", "I = (1, 2, 3)"])
@pytest.mark.parametrize("direction", [(1.0, 1.0, 1.0), (0.1, 1.0, 1.0), (1000.0, 1.0, 1.0), (1.0, 1e-12, 1e-12)])
def test_exact_rotor_is_a_flow_at_the_extremes(shape: str, direction) -> None:
    """One step of 6 s equals six of 1 s (the group property of an exact flow), for thin
    rods tumbling or spinning about their axis, flat strips and near-degenerate bodies,
    with energy and |L| kept to round-off."""
    inertia = np.array([SHAPES[shape]])
    w = np.array([direction], dtype=float)
    w /= np.linalg.norm(w)
    q0 = np.array([[1.0, 0.0, 0.0, 0.0]])
    q1, L1 = exact_rotor(inertia, q0, inertia * w, 6.0)
    q6, L6 = q0, inertia * w
    for _ in range(6):
        q6, L6 = exact_rotor(inertia, q6, L6, 1.0)
    assert quat_angle_between(q1[0], q6[0]) < 1e-8
    np.testing.assert_allclose(L6, L1, rtol=0, atol=1e-9 * np.abs(inertia * w).max())
    for L in (L1, L6):
        assert np.sum(L**2 / inertia) == pytest.approx(np.sum(inertia * w**2), rel=1e-13)
        assert np.linalg.norm(L) == pytest.approx(np.linalg.norm(inertia * w), rel=1e-13)


def test_symmetric_splitting_error_is_proportional_to_the_asymmetry() -> None:
    """The remainder of the splitting is (1/I_k − 1/I_t) L_k²/2 ≈ (r/2) L_k²/2 for a rod: at
    a fixed |ω|h the energy error shrinks in proportion to r."""
    r = np.array([1e-2, 1e-3, 1e-4])
    run = envelope.torque_free_run("symmetric_splitting", np.stack((r, np.ones(3), 1.0 + 0.5 * r), axis=1),
                                   np.full(3, 0.5), 1000)
    assert loglog_slope(r, run.energy_error) == pytest.approx(1.0, abs=0.15), run.energy_error


# ----------------------------------------------------------------------------- the node


@pytest.mark.ros
def test_node_stops_a_diverging_body_and_never_publishes_it(tmp_path) -> None:
    """Explicit Euler on a thin rod tumbling at |ω|h = 0.5: the energy check fires within a
    few ticks; the node stops that body, keeps the other running, and publishes only it."""
    import yaml

    from rigid_body_sim.testing import SimHarness

    scene = {"bodies": {
        "rod": {"mass": 0.1, "inertia": {"principal": [0.01, 1.0, 1.005]}, "twist": {"angular": [0.0, 50.0, 5.0]}},
        "box": {"mass": 2.0, "inertia": {"box": [1.0, 0.6, 0.4]}},
    }}
    path = tmp_path / "rod.yaml"
    path.write_text(yaml.safe_dump(scene))
    core = Simulator(load_scene(path), "euler", 0.01)
    with pytest.raises(DivergenceError):
        core.step(100)
    ticks = core.step_count + 2
    with SimHarness(path, parameters={"integrator": "euler", "wrench_timeout": 0.0}) as node:
        node.publish_wrench("box", force=(2.0, 0.0, 0.0), frame_id="world")
        node.step(core.step_count)
        last_rod = node.latest_pose("rod")
        node.step(ticks - core.step_count)
        assert node.node.simulator.stopped_bodies == ("rod",)
        assert node.latest_pose("rod") is last_rod
        # The box ran on: explicit Euler from rest under a = 1 m/s², x_n = a h² n (n − 1) / 2.
        assert node.latest_pose("box").pose.position.x == pytest.approx(0.01**2 * ticks * (ticks - 1) / 2, rel=1e-9)


# ----------------------------------------------------------------------------- slow: the whole table


@pytest.fixture(scope="module")
def fresh_measurement() -> dict:
    return envelope.measure(jobs=2)


@pytest.mark.slow
def test_envelope_table_is_reproduced_in_full(fresh_measurement: dict) -> None:
    """The whole search, coarse and fine, gives the documented limits, to the search's
    resolution (one fine grid step, a factor 2^(1/32): an error right at the tolerance may
    land either side of it with another CPU's round-off)."""
    documented = _documented()
    step = 2.0 ** (1.0 / envelope.FINE_PER_OCTAVE)
    for name in envelope.SWEPT_INTEGRATORS:
        for body, limit in fresh_measurement["envelope"][name]["limits"].items():
            doc = documented["envelope"][name]["limits"][body]
            assert limit["status"] == doc["status"], (name, body, limit, doc)
            assert doc["limit"] / step * (1 - 1e-12) <= limit["limit"] <= doc["limit"] * step * (1 + 1e-12), (name, body)


@pytest.mark.slow
def test_long_runs_match_the_table_and_the_methods(fresh_measurement: dict) -> None:
    """1e6 steps at |ω|h = 0.01, per integrator, against the table and each method's guarantee.

    * splitting family: |L| to round-off: ≤ ~1 ulp per step, which a slowly turning state may
      repeat step after step, so at most n ε (2.2e-10) — the principal-axis rotations of the
      splittings lose far less (ε θ², θ ~ |ω|h), the exact flow rebuilds L each step (~ε);
    * exact_rotor_splitting: energy to round-off too, at most 2 n ε (E ∝ |L|²);
    * splitting / symmetric_splitting: energy bounded by their O((|ω|h)²) modified energy;
    * rk4: energy drift ≲ n (|ω|h)^5 · C, C ≤ 1 for these bodies (|ω̇| ≤ |ω|², triangle inequality);
    * euler, semi_implicit_euler: |L| and energy grow by (1 + O((|ω|h)²)) per step: diverged;
    * every method: | |q| − 1 | at round-off.
    """
    documented = _documented()["long"]
    n, spin = envelope.LONG_STEPS, envelope.LONG_SPIN_STEP
    for name in envelope.SWEPT_INTEGRATORS:
        run = fresh_measurement["long"][name]
        energy, momentum, stopped = map(np.array, (run["energy_error"], run["momentum_error"], run["stopped_at"]))
        assert run["unit_error"] < 1e-12, name
        if name in SPLITTING_FAMILY:
            assert np.all(stopped == -1) and np.all(momentum < n * EPS), (name, momentum)
        if name == "exact_rotor_splitting":
            assert np.all(energy < 2 * n * EPS), energy
        elif name in ("splitting", "symmetric_splitting"):
            assert np.all(energy < spin**2), (name, energy)
        elif name == "rk4":
            assert np.all(energy < n * spin**5), energy
        elif name in EXPLODING:
            assert np.all(stopped > 0), (name, stopped)
        # The table says the same: to the 2 digits it prints, and below 1e-10 (round-off, which
        # varies with the CPU and numpy build) only that it is round-off; divergence within 1 %.
        doc = documented[name]
        np.testing.assert_allclose(run["stopped_at"], doc["stopped_at"], rtol=0.01, err_msg=name)
        live = (np.array(run["stopped_at"]) < 0) & (np.array(doc["stopped_at"]) < 0)
        for key in ("energy_error", "momentum_error"):
            fresh, old = np.array(run[key]), np.array(doc[key])
            np.testing.assert_allclose(fresh[live], old[live], rtol=0.05, atol=1e-10, err_msg=f"{name} {key}")
