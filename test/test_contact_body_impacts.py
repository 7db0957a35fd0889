"""Impacts between moving bodies through the Simulator (core/contact/body_pairs.py) against closed forms.

* Two spheres (r_a = 0.1 m, r_b = 0.15 m, m_a = 1 kg, m_b = 2.5 kg, no gravity) flying at each
  other, head-on and oblique, frictionless and with friction (sticking and sliding), with spin:
  the impact time is the root of |c_b(t) − c_a(t)| = r_a + r_b (straight lines: a quadratic);
  the velocities and spins after it are the closed form of the project's two-phase law
  (rigid_body_sim/exact/sphere_impact.py: momentum, Poisson's restitution, Coulomb's cone), both
  within 1e-9 relative (rk4 at dt = 1 ms: a straight line and a torque-free sphere's spin are
  exact for it, so only round-off and the event location remain). Both bodies have an event
  naming the other. In one case they touch at a step's start (within the islands' TOUCH × their
  size) and approach: an impact, not the islands' resting contact.
* Energy never rises: random pairs of shapes (sphere, box, capsule, cylinder), orientations,
  spins, materials and offsets (within the smallest half-size: they must meet) flying at each
  other (hypothesis): an impact event (or, e = 0 and touching at a step's end, the islands' inelastic step at
  the next), the kinetic energy after the step holding it ≤ before (1 + 1e-12); every impact event's too. The same pairs set touching at a step's start (within the
  islands' band, or overlapping a little) while closing: an impact event, not the islands' step.
* The same two spheres under gravity, meeting at a step boundary: after it each flies on its own
  integrator's step (the closed-form parabolas within 1e-9 m), not the islands' first-order one.
* A box flying face on at a box (four contact points) and at a sphere: the impact time and the
  1-D textbook velocities, within 1e-9.
* A ball dropped onto a box resting on the ground, e = 0: it stops on it (the ground takes the
  box's share, round after round), the box stays resting. A box sliding on the ground into a
  resting one: both go on at half its speed.
* Events within a group's step keep every body in it: a cube sliding into a resting one against a static wall,
  and one sliding into a wall with a faster one behind it, stop there (the wall's law in the pair's rounds; the
  wall met inside the step), positions and speeds within 1e-9; a ball sliding into one that lifts off the ground
  (in flight, touching it) strikes it and never overlaps it, momentum along the ground kept.
* A box falls onto a box (face on face) and a sphere onto a box: they do not pass through, and
  they come to rest on each other exactly (islands, island.py).
* A can held on its rim whose held step, its holding force held over the piece, would throw it into a can
  falling on it: its end face lands where it was instead, as on the ground pass; K + U of the two never rises.
* A can rocking on its rim with a ball falling onto it: its end face coming down is an event of the pair's step;
  the ball ends no step deeper in it than the pair pass's skin; K + U never rises.
* A can standing near upright whose step in the compiled pass, handed to the solver for an event, threw it: its end
  face lands instead; K + U never rises.
* A can lying on its side, held on one rim point, whose held step would throw it: it stays at rest (only a can
  near upright has its end face land instead); K + U never rises.
* A box held on the ground on one corner, struck again and again by a capsule, with the corner it pivoted on
  touching the ground: that corner takes its share of each blow and lands, and the capsule ends no step deeper in
  the box than the pair pass's skin; K + U never rises.
* A scene with one moving body and no static shape has no body–body pass at all.
* A capsule spinning against a wall, struck there by a spinning box: its Zeno sequence on the wall inside the
  group's step ends after ZENO_IMPACTS impacts, as on the ground pass.
* A crate asleep on the ground, set moving into it as a ball strikes it within the step: struck by the ground at
  the step's start (e = 0 and 0.5), then by the ball; never below the ground.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from contact_support import bin_walls
from hypothesis import example, given, settings
from hypothesis import strategies as st

from rigid_body_sim.core import DivergenceError, Simulator, load_scene
from rigid_body_sim.core.contact.body_pairs import ADVANCE_SKIN, BodyPairs
from rigid_body_sim.core.contact.solver import ZENO_IMPACTS
from rigid_body_sim.core.contact.query import overlapping_bodies
from rigid_body_sim.core.quaternion import quat_rotate
from rigid_body_sim.exact.sphere_impact import two_sphere_impact

RA, RB, MA, MB = 0.1, 0.15, 1.0, 2.5
IA, IB = 0.4 * MA * RA**2, 0.4 * MB * RB**2


def _ball(r, m, position, velocity, spin=(0.0, 0.0, 0.0), e=0.5, mu=0.3):
    return {"mass": m, "inertia": {"sphere": r}, "material": {"restitution": e, "friction": mu},
            "pose": {"position": list(position)}, "twist": {"linear": list(velocity), "angular": list(spin)}}


def _contact_time(c0, v_rel, reach):
    """First t ≥ 0 with |c0 + v_rel t| = reach (c0: b's centre from a's)."""
    c0, v_rel = np.asarray(c0, float), np.asarray(v_rel, float)
    a, b, c = v_rel @ v_rel, 2.0 * c0 @ v_rel, c0 @ c0 - reach**2
    return (-b - math.sqrt(b * b - 4.0 * a * c)) / (2.0 * a)


CASES = {  # name: (b's offset from a, v_a, v_b, ω_a, ω_b, e, μ)
    "head-on frictionless": ((0.6, 0.0, 0.0), (1.0, 0.0, 0.0), (-2.0, 0.0, 0.0), (0, 0, 0), (0, 0, 0), 0.7, 0.0),
    "oblique frictionless": ((0.6, 0.12, -0.05), (1.5, 0.0, 0.0), (-1.0, 0.0, 0.0), (0, 0, 0), (0, 0, 0), 0.5, 0.0),
    "oblique sticking, spin": ((0.6, 0.1, 0.0), (1.0, 0.0, 0.0), (-1.0, 0.0, 0.0), (0, 0, 2.0), (1.0, 0, -1.0), 0.3, 1.0),
    "oblique sliding, spin": ((0.6, 0.15, 0.05), (2.0, 0.2, 0.0), (-1.0, 0.0, 0.3), (0, 3.0, 0), (0, 0, 5.0), 0.8, 0.1),
    # 0.35 m + 50 nm closed at 3.5 m/s: 50 nm apart at the start of step 100 (within the islands' TOUCH × their
    # size, 150 nm): an impact early in that step, not the islands' resting contact
    "head-on, touching at a step's start": ((0.6 + 5e-8, 0.0, 0.0), (1.5, 0.0, 0.0), (-2.0, 0.0, 0.0), (0, 0, 0),
                                            (0, 0, 0), 0.7, 0.0),
}


@pytest.mark.parametrize("name", CASES)
def test_two_spheres_meet_the_closed_form(name):
    offset, va, vb, wa, wb, e, mu = CASES[name]
    pa = np.array([0.0, 0.0, 1.0])
    pb = pa + offset
    scene = load_scene({"gravity": [0.0, 0.0, 0.0], "ground": [],
                        "bodies": {"a": _ball(RA, MA, pa, va, wa, e, mu), "b": _ball(RB, MB, pb, vb, wb, e, mu)}})
    sim = Simulator(scene, "rk4", 1e-3)
    t_hit = _contact_time(offset, np.subtract(vb, va), RA + RB)
    sim.step(int(math.ceil(t_hit / 1e-3)) + 5)
    ev_a, ev_b = sim.contact.events_of("a", "impact"), sim.contact.events_of("b", "impact")
    assert len(ev_a) == len(ev_b) == 1
    assert ev_a[0].other == "b" and ev_b[0].other == "a" and ev_a[0].ground == -1
    assert ev_a[0].time == pytest.approx(t_hit, rel=1e-9)
    # the closed form at the contact configuration
    ca, cb = pa + np.asarray(va) * t_hit, pb + np.asarray(vb) * t_hit
    n = (cb - ca) / np.linalg.norm(cb - ca)
    expect = two_sphere_impact(MA, IA, RA, va, wa, MB, IB, RB, vb, wb, n, e, mu)
    s = sim.state
    got = (s.v_WC_W[0], quat_rotate(s.q_WP[0], s.w_WP_P[0]), s.v_WC_W[1], quat_rotate(s.q_WP[1], s.w_WP_P[1]))
    for x, ref in zip(got, expect):
        scale = max(np.abs(ref).max(), 1.0)
        np.testing.assert_allclose(x, ref, rtol=0.0, atol=1e-9 * scale)
    np.testing.assert_allclose(ev_b[0].normal_world, n, atol=1e-9)
    # and the bodies now separate along the straight lines after the impact
    assert np.linalg.norm(s.p_WC_W[1] - s.p_WC_W[0]) > RA + RB


def test_two_spheres_meeting_at_a_step_boundary_part_on_their_own_steps():
    """Under gravity, the two spheres fly level at each other (0.35 m closed at 3.5 m/s, e = 0.7, frictionless):
    they meet at t = 0.1 s, a step boundary at dt = 1 ms, and touch at the next step's start while parting.
    Each then flies on its own integrator's step, not the islands' (first order: ½ g h² ≈ 5e-6 m off in one
    step): at t = 0.11 s both centres are on the closed form (the 1-D impact velocities, the fall ½ g t², exact
    for rk4) within 1e-9 m."""
    e, g, va, vb = 0.7, 9.81, 1.5, -2.0
    pa, pb = np.array([0.0, 0.0, 1.0]), np.array([0.6, 0.0, 1.0])
    scene = load_scene({"gravity": [0.0, 0.0, -g], "ground": [],
                        "bodies": {"a": _ball(RA, MA, pa, (va, 0, 0), e=e, mu=0.0),
                                   "b": _ball(RB, MB, pb, (vb, 0, 0), e=e, mu=0.0)}})
    sim = Simulator(scene, "rk4", 1e-3)
    sim.step(110)
    t_hit, t = 0.35 / (va - vb), 0.11
    va_after = ((MA - e * MB) * va + (1 + e) * MB * vb) / (MA + MB)
    vb_after = ((MB - e * MA) * vb + (1 + e) * MA * va) / (MA + MB)
    fall = -0.5 * g * t * t
    expect = [(pa[0] + va * t_hit + va_after * (t - t_hit), 0.0, 1.0 + fall),
              (pb[0] + vb * t_hit + vb_after * (t - t_hit), 0.0, 1.0 + fall)]
    assert len(sim.contact.events_of("a", "impact")) == 1
    np.testing.assert_allclose(sim.positions_world(), expect, rtol=0.0, atol=1e-9)


@pytest.mark.parametrize("kind_b", ["box", "sphere"])
def test_a_box_meets_a_box_or_a_sphere_face_on(kind_b):
    """A box (0.2 m cube, 1 kg) flying face on at a box (0.2 m cube, 2 kg: four contact points, the
    clipped face) or centrally at a sphere (r = 0.1 m, 2 kg), no gravity, frictionless, e = 0.6:
    the impact at the closed-form time (gap 0.3 m closed at 3 m/s) and the 1-D textbook velocities
    v_a' = ((m_a − e m_b) v_a + (1 + e) m_b v_b)/(m_a + m_b), no spin (the impulses are symmetric
    about the line of the centres), within 1e-9."""
    e, ma, mb, va, vb = 0.6, 1.0, 2.0, 1.0, -2.0
    shape_b = {"box": [0.2, 0.2, 0.2]} if kind_b == "box" else {"sphere": 0.1}
    bodies = {"a": {"mass": ma, "inertia": {"box": [0.2, 0.2, 0.2]}, "material": {"restitution": e, "friction": 0.0},
                    "pose": {"position": [0.0, 0.0, 1.0]}, "twist": {"linear": [va, 0.0, 0.0]}},
              "b": {"mass": mb, "inertia": shape_b, "material": {"restitution": e, "friction": 0.0},
                    "pose": {"position": [0.5, 0.0, 1.0]}, "twist": {"linear": [vb, 0.0, 0.0]}}}
    sim = Simulator(load_scene({"gravity": [0.0, 0.0, 0.0], "ground": [], "bodies": bodies}), "rk4", 1e-3)
    sim.step(120)
    impacts = sim.contact.events_of("a", "impact")
    assert len(impacts) == 1 and impacts[0].other == "b"
    assert impacts[0].contacts == (4 if kind_b == "box" else 1)
    assert impacts[0].time == pytest.approx(0.3 / 3.0, rel=1e-9)
    va_after = ((ma - e * mb) * va + (1 + e) * mb * vb) / (ma + mb)
    vb_after = ((mb - e * ma) * vb + (1 + e) * ma * va) / (ma + mb)
    np.testing.assert_allclose(sim.state.v_WC_W, [[va_after, 0, 0], [vb_after, 0, 0]], rtol=0.0, atol=1e-9)
    np.testing.assert_allclose(sim.state.w_WP_P, 0.0, atol=1e-9)


def test_a_box_meets_a_box_turned_45_degrees_face_on():
    """The same with b turned 45° about the line of the centres: the clipped faces overlap in an octagon
    (8 contact points, more than the impact law's 4 rows: the 4 spanning ones are kept,
    body_pairs._spanning). The 1-D textbook velocities within 1e-9, momentum conserved."""
    e, ma, mb, va, vb = 0.6, 1.0, 2.0, 1.0, -2.0
    s45 = math.sin(math.pi / 8.0)
    bodies = {"a": {"mass": ma, "inertia": {"box": [0.2, 0.2, 0.2]}, "material": {"restitution": e, "friction": 0.0},
                    "pose": {"position": [0.0, 0.0, 1.0]}, "twist": {"linear": [va, 0.0, 0.0]}},
              "b": {"mass": mb, "inertia": {"box": [0.2, 0.2, 0.2]}, "material": {"restitution": e, "friction": 0.0},
                    "pose": {"position": [0.5, 0.0, 1.0], "orientation": [s45, 0.0, 0.0, math.cos(math.pi / 8.0)]},
                    "twist": {"linear": [vb, 0.0, 0.0]}}}
    sim = Simulator(load_scene({"gravity": [0.0, 0.0, 0.0], "ground": [], "bodies": bodies}), "rk4", 1e-3)
    sim.step(120)
    impacts = sim.contact.events_of("a", "impact")
    assert len(impacts) == 1 and impacts[0].other == "b" and impacts[0].contacts == 4
    va_after = ((ma - e * mb) * va + (1 + e) * mb * vb) / (ma + mb)
    vb_after = ((mb - e * ma) * vb + (1 + e) * ma * va) / (ma + mb)
    np.testing.assert_allclose(sim.state.v_WC_W, [[va_after, 0, 0], [vb_after, 0, 0]], rtol=0.0, atol=1e-9)
    np.testing.assert_allclose(ma * sim.state.v_WC_W[0] + mb * sim.state.v_WC_W[1], [ma * va + mb * vb, 0, 0],
                               rtol=0.0, atol=1e-12)


_KINDS = {"sphere": lambda d: {"sphere": d[0]}, "box": lambda d: {"box": list(d)},
          "capsule": lambda d: {"capsule": [d[0], d[1]]}, "cylinder": lambda d: {"cylinder": [d[0], d[1]]}}


def _shape(kind, dims):
    shape = _KINDS[kind](dims)
    inertia = shape if kind != "capsule" else {"cylinder": [dims[0], dims[1] + 2 * dims[0]]}
    return shape, inertia


def _energy(sim):
    s = sim.state
    total = 0.0
    for i in range(2):
        prm = sim._prm[i]
        total += 0.5 * prm[0] * s.v_WC_W[i] @ s.v_WC_W[i] + 0.5 * prm[2:5] @ s.w_WP_P[i] ** 2
    return total


_unit = st.floats(-1.0, 1.0)
#: Random pairs of shapes, orientations, masses and materials (the properties below draw from these).
_PAIRS = dict(
    kinds=st.tuples(st.sampled_from(sorted(_KINDS)), st.sampled_from(sorted(_KINDS))),
    dims=st.tuples(st.floats(0.05, 0.15), st.floats(0.05, 0.15), st.floats(0.05, 0.15)),
    quats=st.lists(_unit, min_size=8, max_size=8).filter(lambda q: min(np.linalg.norm(q[:4]), np.linalg.norm(q[4:])) > 0.1),
    masses=st.tuples(st.floats(0.2, 5.0), st.floats(0.2, 5.0)),
    e=st.floats(0.0, 1.0), mu=st.floats(0.0, 1.5))


def _flying_pair(kinds, dims, quats, masses, e, mu, spins=(0.0,) * 6, offset=(0.0, 0.0)) -> Simulator:
    """a at x = 0 and b at x = 0.8 m (offset in y, z), flying at each other at 2 m/s each, no gravity.
    implicit_gyroscopic keeps a free body's energy exactly at any |ω|h, so a step's change is the
    contact's alone (rk4's own truncation error on the spin an impact leaves reaches 1e-11 of E)."""
    bodies = {}
    for k, (name, x, vx) in enumerate((("a", 0.0, 2.0), ("b", 0.8, -2.0))):
        shape, inertia = _shape(kinds[k], dims)
        q = np.asarray(quats[4 * k:4 * k + 4]) / np.linalg.norm(quats[4 * k:4 * k + 4])
        bodies[name] = {"mass": masses[k], "inertia": inertia, "collision": shape,
                        "material": {"restitution": e, "friction": mu},
                        "pose": {"position": [x, offset[0] * k, 1.0 + offset[1] * k],
                                 "orientation": [float(q[1]), float(q[2]), float(q[3]), float(q[0])]},
                        "twist": {"linear": [vx, 0.0, 0.0], "angular": list(spins[3 * k:3 * k + 3])}}
    return Simulator(load_scene({"gravity": [0.0, 0.0, 0.0], "ground": [], "bodies": bodies}), "implicit_gyroscopic", 2e-3)


@settings(max_examples=25, deadline=None)
@example(kinds=("box", "box"), dims=(0.125, 0.05078125, 0.0625), quats=[0.0, 1.0, 0.5, 0.0, 0.0, 0.0, 0.0, 1.0],
         spins=[0.0, 0.0, 0.0, 0.0, -1.0, 1.5], offset=(0.0, 0.0), masses=(1.0, 1.0), e=1.0, mu=0.0)
@example(kinds=("sphere", "sphere"), dims=(0.1, 0.125, 0.125), quats=[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
         spins=[0.0] * 6, offset=(0.0, 1.192092896e-07), masses=(1.0, 1.0), e=0.0, mu=0.0)  # touch at a step's end
@given(**_PAIRS, spins=st.lists(st.floats(-3.0, 3.0), min_size=6, max_size=6),
       offset=st.tuples(st.floats(-0.02, 0.02), st.floats(-0.02, 0.02)))
def test_energy_never_rises_at_a_body_body_impact(kinds, dims, quats, spins, offset, masses, e, mu):
    sim = _flying_pair(kinds, dims, quats, masses, e, mu, spins, offset)
    before = _energy(sim)
    for _ in range(150):  # until they meet: an impact event, or (e = 0, touching at a step's end) the islands' step
        sim.step()
        if sim.contact.events or sim.contact.counts["island_body_steps"]:
            break
    assert sim.contact.events or sim.contact.counts["island_body_steps"], "the bodies flew at each other and met"
    assert _energy(sim) <= before * (1.0 + 1e-12)
    for event in sim.contact.events:
        assert event.energy_after <= event.energy_before * (1.0 + 1e-12)


@settings(max_examples=25, deadline=None)
@example(kinds=("box", "cylinder"), dims=(0.1, 0.08, 0.06), quats=[1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0],
         masses=(4.0, 0.4), e=0.0, mu=0.5, gap=0.5)
@example(kinds=("sphere", "box"), dims=(0.1, 0.08, 0.06), quats=[1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0],
         masses=(1.0, 1.0), e=0.5, mu=0.5, gap=0.5)
@example(kinds=("capsule", "capsule"), dims=(0.0703125, 0.125, 0.125),  # left 1.33e-13 m deep: 0.95 × the tolerance
         quats=[0.5, 0.53125, -0.75, 0.28125, 0.0, 0.5, 0.6875, 1.0], masses=(0.203125, 0.40625), e=0.0, mu=1.0,
         gap=0.0)
@given(**_PAIRS, gap=st.floats(-0.5, 0.9))
def test_a_pair_touching_at_a_step_start_while_it_strikes_is_an_impact(kinds, dims, quats, masses, e, mu, gap):
    """Random pairs of shapes (as above, no spin) set at a step's start at a signed distance of gap × the islands'
    TOUCH × the pair's size (the band the islands take as touching; overlapping when gap < 0), closing at 4 m/s:
    they strike. With restitution, the step holds an impact event for both bodies and the islands take no step;
    without (e = 0), the islands' velocity step is the inelastic impact (with whatever else the two touch, as a
    ground under one): it takes both bodies, and stops them closing (after the step they are apart or touching,
    within the projection's tolerance, where closing on at 4 m/s they would overlap by 8 mm). Either way the
    kinetic energy does not rise."""
    from rigid_body_sim.core.kernels.contact.island import PROJECT_TOL, TOUCH
    from rigid_body_sim.core.kernels import layout as L

    sim = _flying_pair(kinds, dims, quats, masses, e, mu)
    pairs = sim.contact.pairs
    size = max(pairs.islands.size[0], pairs.islands.size[1])  # the pair's size as the islands take it: its extent
    target = gap * TOUCH * size
    ya, yb = sim.state.rows()[0].copy(), sim.state.rows()[1].copy()
    lo, hi = 0.0, 0.8  # b's x: overlapping, apart
    for _ in range(200):  # bisection on the signed distance (continuous in x) to round-off
        yb[L.P] = 0.5 * (lo + hi)
        if pairs.contact(ya, 0, yb, 1) < target:
            lo = yb[L.P]
        else:
            hi = yb[L.P]
    sim.set_body_state("b", position_world=(hi, 0.0, 1.0))
    before = _energy(sim)
    sim.step()
    if e > 0.0:
        assert sim.contact.events_of("a", "impact") and sim.contact.events_of("b", "impact")
        assert sim.contact.counts["island_body_steps"] == 0
    else:
        assert sim.contact.counts["island_body_steps"] == 2
        assert not sim.contact.events_of("a", "impact")
        rows = sim.state.rows()
        assert pairs.contact(rows[0], 0, rows[1], 1) >= min(target, 0.0) - PROJECT_TOL * size
    assert _energy(sim) <= before * (1.0 + 1e-12)


def test_a_ball_dropped_onto_a_resting_box_stops_on_it():
    """A ball (0.5 kg, r = 0.05 m) dropped 0.3 m onto the middle of a box (2 kg) resting on the ground,
    e = 0 everywhere: the ground under the box takes what the ball drives in, round after round
    (body_pairs.py), which for e = 0 converges to the ball stopped by an immovable box: the impact
    at t = √(2h/g), the ball's velocity jump +√(2gh) (1e-9 relative), the box still resting: no
    lift-off; from the next step the two are one island (island.py), both at rest to round-off."""
    g, drop = 9.81, 0.3
    bodies = {"box": {"mass": 2.0, "inertia": {"box": [0.4, 0.4, 0.2]}, "material": {"restitution": 0.0, "friction": 0.5},
                      "pose": {"position": [0.0, 0.0, 0.1]}},
              "ball": {"mass": 0.5, "inertia": {"sphere": 0.05}, "material": {"restitution": 0.0, "friction": 0.5},
                       "pose": {"position": [0.0, 0.0, 0.2 + 0.05 + drop]}}}
    sim = Simulator(load_scene({"gravity": [0.0, 0.0, -g], "ground": [{"normal": [0, 0, 1], "material":
                                                                     {"restitution": 0.0, "friction": 0.5}}],
                                "bodies": bodies}), "rk4", 1e-3)
    t_hit = math.sqrt(2.0 * drop / g)
    sim.step(int(t_hit / 1e-3) + 2)
    ball = sim.contact.events_of("ball", "impact")
    assert len(ball) >= 1 and ball[0].other == "box"
    assert ball[0].time == pytest.approx(t_hit, rel=1e-9)
    assert ball[0].delta_v_world[2] == pytest.approx(math.sqrt(2.0 * g * drop), rel=1e-9)
    assert not sim.contact.events_of("box", "lift-off")
    assert sim.contact.in_island("box") and sim.contact.in_island("ball")
    assert abs(sim.state.v_WC_W).max() <= 1e-9 and abs(sim.state.w_WP_P).max() <= 1e-9
    assert sim.state.p_WC_W[0, 2] == pytest.approx(0.1, abs=1e-12)
    assert sim.state.p_WC_W[1, 2] == pytest.approx(0.25, abs=1e-12)


@pytest.mark.parametrize("integrator", ["rk4", "semi_implicit_euler", "euler"])
def test_a_ball_dropped_off_centre_onto_a_ball_resting_on_the_ground_moves_it_without_a_blow_up_error(integrator):
    """A ball (5 kg, r = 36.9 mm) dropped 20 mm onto a frictionless ball (5 kg, r = 52.7 mm) resting on the ground,
    22 mm off its top, e = 0, dt = 1 ms: the lower ball, locked at rest, takes energy from the upper one through
    their contact (it rolls off sideways). Contact passes energy between bodies and never adds it, so that is not a
    blow-up: no DivergenceError (its bound was the resting ball's √K ≈ 0, and the next step raised one), and the
    energy of the two never rises above its start (1e-12 J) over 2 s."""
    r_low, r_top, mass = 0.05268390686992388, 0.03689113879243165, 5.0
    material = {"restitution": 0.0, "friction": 0.0}
    bodies = {"a": {"mass": mass, "inertia": {"sphere": r_low}, "material": material, "pose": {"position": [0, 0, r_low]}},
              "b": {"mass": mass, "inertia": {"sphere": r_top}, "material": material,
                    "pose": {"position": [0.02, 0.01, 2.0 * r_low + r_top + 0.02]}}}
    sim = Simulator(load_scene({"gravity": [0.0, 0.0, -9.81], "ground": [{"normal": [0, 0, 1], "material": material}],
                                "bodies": bodies}), integrator, 1e-3)

    def energy():
        return _energy(sim) + 9.81 * mass * float(sim.state.p_WC_W[:, 2].sum())

    start = energy()
    for _ in range(2000):
        sim.step()
        assert energy() <= start + 1e-12
    assert np.linalg.norm(sim.state.v_WC_W[0]) > 0.01  # the lower ball was set moving


def test_a_pebble_whose_held_step_blows_up_on_the_ground_is_a_blow_up_at_the_next_step():
    """A 1 cm pebble (32.6 g) landing on the ground beside a crate at rest far away, twisted by 1.9 N applied 6 cm
    off its centre (0.11 N·m, rk4 at dt = 5 ms): its held step, rolling at every stage, is unstable at that
    |ω| h and spins it up ×3700 in one step. The ground never passes energy on, so its blow-up bound is not raised
    to its kinetic energy as a body's that met another body's is: the next step raises DivergenceError, the state
    left where the spin was 3e7 rad/s. (Raised, the bound hid it: the step after took the pebble to 9e35 rad/s and
    the next to |ω| beyond what a float's square holds.)"""
    ball, box = {"sphere": 0.005}, {"box": [0.2, 0.2, 0.2]}
    bodies = {"pebble": {"mass": 0.032640323883172444, "inertia": ball, "collision": ball,
                         "material": {"restitution": 0.0, "friction": 1.002683059800329},
                         "pose": {"position": [0.3208277433460176, -0.06787100551692293, 0.010464924562450384]},
                         "twist": {"linear": [0.0, 0.0, -2.2563]}},
              "crate": {"mass": 1.0, "inertia": box, "collision": box, "pose": {"position": [2.0, 0.0, 0.1]}}}
    sim = Simulator(load_scene({"gravity": [0.0, 0.0, -9.81], "bodies": bodies,
                                "ground": [{"normal": [0, 0, 1], "material": {"restitution": 0.0, "friction": 0.5}}]}),
                    "rk4", 5e-3, threads=1)
    sim.contact.sleeping = True
    force = [0.9908623985266142, 1.1103709094333032, -1.1035896001435768]
    at = [0.34185340771079636, -0.05489283257231995, -0.06015413621113839]
    with pytest.raises(DivergenceError, match="pebble"):
        for _ in range(8):
            sim.apply_force_at_point("pebble", force, at)
            sim.step()
            assert np.abs(sim.angular_velocities_world()[0]).max() < 1e9
    assert np.abs(sim.angular_velocities_world()[0]).max() < 1e9
    assert np.array_equal(sim.positions_world()[1], [2.0, 0.0, 0.1])


def _on_the_ground(bodies: dict, material: dict) -> Simulator:
    """``bodies`` over a ground of ``material`` (normal +z), g = 9.81 m/s², rk4 at dt = 10 ms, one thread."""
    return Simulator(load_scene({"gravity": [0.0, 0.0, -9.81], "ground": [{"normal": [0, 0, 1], "material": material}],
                                 "bodies": bodies}), "rk4", 1e-2, threads=1)


def _never_above_start(sim: Simulator, masses: np.ndarray, steps: int, apart: bool = False) -> None:
    """Step ``steps`` times: the energy K + U of the two bodies (``masses``) never rises above its start (1e-12 of
    it); with ``apart``, no step ends with one deeper in the other than the pair pass's skin (ADVANCE_SKIN × the
    pair's size)."""

    def energy():
        return _energy(sim) + 9.81 * float(masses @ sim.state.p_WC_W[:2, 2])

    pairs = sim.contact.pairs
    skin = ADVANCE_SKIN * max(pairs.size[0], pairs.size[1])
    start = energy()
    for _ in range(steps):
        sim.step()
        assert energy() <= start + 1e-12 * start
        rows = sim.state.rows()
        assert not apart or pairs.contact(rows[0], 0, rows[1], 1) >= -skin


def test_a_ball_bouncing_on_a_can_that_rocks_on_its_rim_never_adds_energy():
    """A ball (0.2 kg, r = 72.5 mm, e = 0.7, μ = 0.8 everywhere) dropped 124 mm onto a can (5 kg, r = 90.9 mm,
    181.8 mm long) set 1 mm above the ground, 79.7 mm off its axis (a case a random scan found; rk4 at dt = 10 ms): it
    bounces on the can's edge, the can rocks on its rim near upright. The events of a step with the two are looked for
    piece by piece while the can's rim turns fast, each piece's holding force found afresh, as on the ground pass
    (advanced in one piece the can's rim force, found at every stage, grew as 1/sin³ θ near upright: 0.70 J gained in
    one step). The energy of the two never rises above its start (1e-12 of it) over 2 s."""
    material = {"restitution": 0.7, "friction": 0.8}
    can = {"cylinder": [0.09087523251273448, 0.18175046502546896]}
    bodies = {"can": {"mass": 5.0, "inertia": can, "collision": can, "material": material,
                      "pose": {"position": [0.0, 0.0, 0.09187523251273448]}},
              "ball": {"mass": 0.2, "inertia": {"sphere": 0.0724622837688701}, "material": material,
                       "pose": {"position": [0.0788018919030564, 0.011661645320309912, 0.3792757066338215],
                                "orientation": [-0.005886364745143162, 0.02697678554369221, -0.45215250910636745,
                                                -0.8915131587703196]}}}
    _never_above_start(_on_the_ground(bodies, material), np.array([5.0, 0.2]), 200)


def test_a_ball_the_ground_sends_back_meets_the_ball_above_it_in_the_same_step():
    """Two balls (1 kg, r = 50 mm, e = 1, frictionless) one above the other over the ground (e = 1), no gravity: the
    lower 1 mm above the ground at 2 m/s down, the upper 2 mm above it at 1 m/s down (rk4, dt = 10 ms). On their
    free paths they draw apart (the broad phase lists no pair); the lower bounces off the ground at 0.5 ms, meets the
    upper at 4/3 ms (equal masses, e = 1: they swap velocities) and bounces off the ground again at 3 ms. After the
    step each is where the closed form has it (1e-12 m, 1e-12 m/s), the events at its times (1e-12 s), and the
    step was taken again once (counted in ``pairs_looked_again``)."""
    r, g0, s0, h = 0.05, 0.001, 0.002, 0.01
    material = {"restitution": 1.0, "friction": 0.0}
    bodies = {"lower": _ball(r, 1.0, (0.0, 0.0, r + g0), (0.0, 0.0, -2.0), e=1.0, mu=0.0),
              "upper": _ball(r, 1.0, (0.0, 0.0, 3.0 * r + g0 + s0), (0.0, 0.0, -1.0), e=1.0, mu=0.0)}
    sim = Simulator(load_scene({"gravity": [0.0, 0.0, 0.0], "ground": [{"normal": [0, 0, 1], "material": material}],
                                "bodies": bodies}), "rk4", h, threads=1)
    sim.step()
    t1 = g0 / 2.0  # the lower one's bounce
    t2 = t1 + (s0 + (2.0 - 1.0) * t1) / 3.0  # the two meet, closing at 3 m/s, and swap velocities
    z_lower = r + 2.0 * (t2 - t1)
    t3 = t2 + (z_lower - r) / 1.0  # the lower one's second bounce
    np.testing.assert_allclose(sim.state.p_WC_W[:, 2], [r + (h - t3), z_lower + 2.0 * r + 2.0 * (h - t2)], rtol=0,
                               atol=1e-12)
    np.testing.assert_allclose(sim.state.v_WC_W, [[0.0, 0.0, 1.0], [0.0, 0.0, 2.0]], rtol=0, atol=1e-12)
    times = [(e.body, e.other, e.time) for e in sim.contact.events if e.kind == "impact"]
    assert [(b, o) for b, o, _ in times] == [("lower", ""), ("lower", "upper"), ("upper", "lower"), ("lower", "")]
    np.testing.assert_allclose([t for *_, t in times], [t1, t2, t2, t3], rtol=0, atol=1e-12)
    assert sim.contact.counts["pairs_looked_again"] == 1


def test_a_spinning_box_dropped_on_a_can_does_not_throw_it():
    """A box (5 kg, 89.7 × 71.8 × 53.8 mm) dropped spinning (2.5 rad/s) onto a can (1 kg, r = 52 mm, 104 mm long) set
    1 mm above the ground, e = 0.7 and μ = 0.3 everywhere (a case a random scan found; rk4 at dt = 10 ms). The can,
    struck, bounces between the box and the ground, up to some two hundred events in a step, and rocks on its rim
    near upright. A pair touching after an impact and not approaching is followed for the rest of the step:
    unfollowed, the box went 8.8 mm into the can, whose rim force, found at every stage near upright, then threw
    it. The energy of the two never rises above its start (1e-12 of
    it) over 2 s, and no step ends with the box deeper in the can than the pair pass's skin (ADVANCE_SKIN × the
    pair's size)."""
    material = {"restitution": 0.7, "friction": 0.3}
    can = {"cylinder": [0.05195137897832766, 0.10390275795665532]}
    box = {"box": [0.08968886686057002, 0.07175109348845603, 0.05381332011634201]}
    bodies = {"can": {"mass": 1.0, "inertia": can, "collision": can, "material": material,
                      "pose": {"position": [0.0, 0.0, 0.05295137897832766]}},
              "box": {"mass": 5.0, "inertia": box, "collision": box, "material": material,
                      "pose": {"position": [0.0187034706129072, 0.0005300623990115619, 0.2310562977322942],
                               "orientation": [-0.055991024981398116, 0.01938076719732675, 0.0018951883106025893,
                                               0.9982413532035441]},
                      "twist": {"angular": [-0.23005828832214964, -1.9745595267553742, -1.4489225402347006]}}}
    _never_above_start(_on_the_ground(bodies, material), np.array([1.0, 5.0]), 200, apart=True)


def test_a_box_falling_onto_a_box_tipping_beside_a_wall_ends_no_step_inside_it():
    """A box (3.3 kg, 67.6 × 129 × 103 mm, frictionless, e = 0) falling at 3.4 m/s, spinning, onto a box (2.3 kg,
    120 × 163 × 119 mm, μ = 0.029) standing 20 µm above the ground and touching a wall (rk4 at dt = 5 ms; a case a
    mixed pile gave). The lower box, struck on its edge, tips on the ground and slams back flat while the upper one
    rides on it and on the wall, some forty events in the first step: each landing of the lower box's other edge is
    an event of the pair pass, and a pair touching after an impact is followed on. No step of 0.1 s ends with the upper box deeper in the lower than the pair pass's skin
    (ADVANCE_SKIN × the pair's size), and K + U never rises above its start (1e-12 of it)."""
    lower = {"box": [0.1196153711080292, 0.16333327062734618, 0.11881858497869019]}
    upper = {"box": [0.06764387584437448, 0.12924208749251154, 0.10269876632233799]}
    wall = {"box": [0.1, 1.65, 1.0]}
    scene = {"gravity": [0.0, 0.0, -9.81],
             "ground": [{"normal": [0, 0, 1], "offset": 0.0, "material": {"restitution": 0.0, "friction": 0.6}}],
             "bodies": {
                 "lower": {"mass": 2.3246026649304694, "inertia": lower, "collision": lower,
                           "material": {"restitution": 0.0, "friction": 0.028716033628026237},
                           "pose": {"position": [0.6651615667238763, -0.5662307409514125, 0.059429292489345094],
                                    "orientation": [0.0, 0.0, 0.00010846011556659665, 0.9999999941182017]},
                           "twist": {"linear": [0.006274109942954378, -0.05278677396980399, 0.0],
                                     "angular": [0.0, 0.0, 0.06958533594509238]}},
                 "upper": {"mass": 3.3239980568389464, "inertia": upper, "collision": upper,
                           "material": {"restitution": 0.0, "friction": 0.0},
                           "pose": {"position": [0.6538545023773431, -0.5849440573219706, 0.17258214030834798],
                                    "orientation": [0.0032204979229770504, -0.007039014654396897, 0.9085886433962084,
                                                    0.4176203512249626]},
                           "twist": {"linear": [0.07418796128650343, -0.3071843101118435, -3.3572940352423672],
                                     "angular": [0.20551766045026162, 0.33026318215693556, 3.7782566776884976]}},
                 "wall": {"motion": "static", "mass": 1.0, "inertia": wall, "collision": wall,
                          "material": {"restitution": 0.0, "friction": 0.5}, "pose": {"position": [0.775, 0.0, 0.5]}}}}
    sim = Simulator(load_scene(scene), integrator="rk4", dt=5e-3, threads=1)
    _never_above_start(sim, np.array([2.3246026649304694, 3.3239980568389464]), 20, apart=True)


def test_a_box_held_on_a_corner_pressed_by_a_capsule_lands_on_its_face_and_ends_no_step_inside_it():
    """A box (3.35 kg, 74.7 × 132 × 194 mm, μ = 0.79, e = 0) tipping on the ground, its centre falling at 0.54 m/s,
    and a capsule (3.0 kg, r = 37 mm, 44 mm long, frictionless) falling onto it at 2.6 m/s, 1.7 mm above it
    (semi-implicit Euler at dt = 10 ms; a state a mixed pile gave). In the first step the capsule strikes the box
    ten times, while the box, landed on a second corner and held on that one alone, turns the corner it pivoted on,
    still touching the ground, into it: the ground takes that corner's share of each blow, and its coming down is
    followed to a skin below the ground, where it lands, and the box rests on its face. (The pair pass followed
    only corners apart from the ground: the box sank 6.8 mm into it within the step, and the ground pass lifting it
    back out at the step's end put it 4.0 mm into the capsule.) No step of 0.2 s ends with the capsule deeper in the box than
    the pair pass's skin (ADVANCE_SKIN × the pair's size), and K + U never rises above its start (1e-12 of it)."""
    box = {"box": [0.07472232121404399, 0.13225288340539815, 0.19430112238451042]}
    capsule = {"capsule": [0.037383631085788786, 0.04427693224933546]}
    scene = {"gravity": [0.0, 0.0, -9.81],
             "ground": [{"normal": [0, 0, 1], "offset": 0.0, "material": {"restitution": 0.0, "friction": 0.6}}],
             "bodies": {
                 "box": {"mass": 3.354985276976695, "inertia": box, "collision": box,
                         "material": {"restitution": 0.0, "friction": 0.7929917230119307},
                         "pose": {"position": [-0.5504001577895177, -0.21377141197210248, 0.04119093643479703],
                                  "orientation": [-0.5975865209026648, -0.379146881760635, -0.61691308890908,
                                                  0.34431995704474294]},
                         "twist": {"linear": [0.20828486212903446, 0.22350052428035383, -0.540439899925706],
                                   "angular": [3.976767320776437, 8.012215452716859, 1.0178844430428686]}},
                 "capsule": {"mass": 3.0045413692500627,
                             "inertia": {"cylinder": [0.037383631085788786, 0.11904419442091303]},
                             "collision": capsule, "material": {"restitution": 0.0, "friction": 0.0},
                             "pose": {"position": [-0.5754141892892619, -0.21624890125896612, 0.12635369047913658],
                                      "orientation": [-0.8332588158567259, -0.19081160877798828, -0.16330912243880258,
                                                      0.4925452327257582]},
                             "twist": {"linear": [-0.29850533928005174, 0.14949583408696573, -2.6246786535202187],
                                       "angular": [-2.6617371858844825, 2.7100455687467915, -0.24860009150323936]}}}}
    sim = Simulator(load_scene(scene), integrator="semi_implicit_euler", dt=1e-2, threads=1)
    _never_above_start(sim, np.array([3.354985276976695, 3.0045413692500627]), 20, apart=True)


def test_a_can_rocking_on_its_rim_under_a_falling_ball_lands_its_face_within_the_pair_s_step():
    """A can (1.72 kg, r = 38 mm, 149 mm long, frictionless, e = 0) rocking on its rim, its centre falling at
    0.38 m/s, and a ball (4.0 kg, r = 61 mm) falling onto it at 1.5 m/s, 4 mm above it (semi-implicit Euler at
    dt = 10 ms; a state a mixed pile gave). The can's end face coming down flat within the pair's step is an event
    of the pair pass, as a box's other edge is: it lands there, before the ball strikes it. (Not followed, the face
    went 1.6 mm into the ground before the ball's blow; with the ground taking that blow at every feature touching
    it, the can was then held there, and the ball ended 5.9 mm inside it.) No step of 0.2 s ends with the ball
    deeper in the can than the pair pass's skin, and K + U never rises above its start (1e-12 of it)."""
    can = {"cylinder": [0.038289745889627, 0.14850738028329688]}
    ball = {"sphere": 0.061094240991385496}
    slick = {"restitution": 0.0, "friction": 0.0}
    scene = {"gravity": [0.0, 0.0, -9.81],
             "ground": [{"normal": [0, 0, 1], "offset": 0.0, "material": {"restitution": 0.0, "friction": 0.6}}],
             "bodies": {
                 "can": {"mass": 1.7163517537400321, "inertia": can, "collision": can, "material": slick,
                         "pose": {"position": [0.24065268692682057, -0.1283348648225178, 0.03890898626364186],
                                  "orientation": [-0.5201585949018805, 0.48333611746270805, 0.37510498399042136,
                                                  0.5959173471978497]},
                         "twist": {"linear": [0.5603237528371232, -0.06793097793810743, -0.38355411582065924],
                                   "angular": [5.836565427156192, 2.9429484314512697, 1.9407915151290407]}},
                 "ball": {"mass": 4.016008608497218, "inertia": ball, "collision": ball, "material": slick,
                          "pose": {"position": [0.29240867568394396, -0.2071125422479163, 0.11949028320729396]},
                          "twist": {"linear": [-0.35206876596577563, -0.23849510404912064, -1.4597974373187985],
                                    "angular": [-1.0714939335951885, 4.537876783841494, -0.3085741631727438]}}}}
    sim = Simulator(load_scene(scene), integrator="semi_implicit_euler", dt=1e-2, threads=1)
    _never_above_start(sim, np.array([1.7163517537400321, 4.016008608497218]), 20, apart=True)


def test_a_capsule_rolling_into_a_wall_struck_from_above_ends_no_step_inside_either():
    """A capsule (4.5 kg, r 33 mm, 113 mm long, frictionless) moving on the ground at 0.49 m/s, 0.40 m/s of it
    toward a wall 0.65 mm away, struck from above by a ball (3.3 kg, r 78 mm, e = 0.076) falling at 3.4 m/s (rk4 at dt = 10 ms; a
    case a mixed pile gave). The capsule meets the wall at 1.5 ms and the ball at 8.3 ms, which drives it into the
    wall it touches: that wall's impact is the group's, at once, and the wall stays in view for the rest of the
    step. Over 3 steps no shape ends deeper in another than the pair pass's skin (ADVANCE_SKIN × the larger size),
    and K + U never rises above its start (1e-12 of it)."""
    wall = {"box": [1.65, 0.1, 1.0]}
    scene = {"gravity": [0.0, 0.0, -9.81],
             "ground": [{"normal": [0, 0, 1], "offset": 0.0, "material": {"restitution": 0.0, "friction": 0.6}}],
             "bodies": {
                 "capsule": {"mass": 4.490152075751307, "inertia": {"cylinder": [0.03338863704621533, 0.1793270488594026]},
                     "collision": {"capsule": [0.03338863704621533, 0.11254977476697194]},
                     "material": {"restitution": 0.0, "friction": 0.0},
                     "pose": {"position": [0.5845571063313574, 0.663079701452315, 0.03338863704621533],
                              "orientation": [-0.45762882683783707, -0.5390508852112432, 0.1304335195334756, 0.6949727311068475]},
                     "twist": {"linear": [0.2713524210704908, 0.40431192069171507, -9.818818400153388e-19],
                               "angular": [0.8899315366767471, -0.5076077618654741, -0.6534523851167029]}},
                 "ball": {"mass": 3.31622030624216, "inertia": {"sphere": 0.0782412487590709},
                     "collision": {"sphere": 0.0782412487590709},
                     "material": {"restitution": 0.076280103157291, "friction": 0.0},
                     "pose": {"position": [0.541874680314708, 0.628654161713313, 0.16252810765527803],
                              "orientation": [-0.10621053901017861, 0.16542254345558383, 0.0521402980800631, 0.9790996337635794]},
                     "twist": {"linear": [0.8353120039760804, 0.3474929518201109, -3.3282219231797874],
                               "angular": [-0.4253163132457793, 0.7368937531880942, 0.22110065340838964]}},
                 "wall": {"motion": "static", "mass": 1.0, "inertia": wall, "collision": wall,
                          "material": {"restitution": 0.0, "friction": 0.5}, "pose": {"position": [0.0, 0.775, 0.5]}}}}
    sim = Simulator(load_scene(scene), integrator="rk4", dt=1e-2, threads=1)
    masses = np.array([4.490152075751307, 3.31622030624216])
    start = _energy(sim) + 9.81 * float(masses @ sim.state.p_WC_W[:2, 2])
    skin = ADVANCE_SKIN * float(sim.contact.pairs.size.max())
    moving = np.array([m != "static" for m in sim.model.motions])
    for _ in range(3):
        sim.step()
        assert _energy(sim) + 9.81 * float(masses @ sim.state.p_WC_W[:2, 2]) <= start + 1e-12 * start
        overlaps = overlapping_bodies(sim.positions_world(), sim.orientations_xyzw()[:, [3, 0, 1, 2]],
                                      sim.contact.shapes, moving)
        assert all(depth <= skin for _, _, depth in overlaps), overlaps


_DROP_DIMS = {"sphere": lambda s: (s, s, s), "box": lambda s: (2.0 * s, 1.6 * s, 1.2 * s),
              "cylinder": lambda s: (s, 2.0 * s, 0.0), "capsule": lambda s: (0.6 * s, 1.6 * s, 0.0)}
#: each kind's height standing on the ground (a capsule lying on its side) and its reach from its centre, / size
_DROP_HEIGHT, _DROP_REACH = {"sphere": 2.0, "box": 1.2, "cylinder": 2.0, "capsule": 1.2}, 1.5


def _dropped_pair(kinds, sizes, masses, e, mu, dt, offset, drop, quat, spin) -> Simulator:
    """Body "top" (kinds[1], size sizes[1]) turned by quat (w, x, y, z) and spinning (rad/s, world), offset (m, x
    and y) and drop (m) above body "low" (kinds[0]) standing on the ground (a capsule lying), one material; rk4."""
    (lower, top), (s_low, s_top) = kinds, sizes
    material = {"restitution": e, "friction": mu}
    bodies = {}
    for name, kind, size, mass in (("low", lower, s_low, masses[0]), ("top", top, s_top, masses[1])):
        shape, inertia = _shape(kind, _DROP_DIMS[kind](size))
        bodies[name] = {"mass": mass, "inertia": inertia, "collision": shape, "material": material}
    lying = [math.sin(math.pi / 4), 0.0, 0.0, math.cos(math.pi / 4)] if lower == "capsule" else [0.0, 0.0, 0.0, 1.0]
    height = _DROP_HEIGHT[lower] * s_low
    bodies["low"]["pose"] = {"position": [0.0, 0.0, 0.5 * height + 1e-3], "orientation": lying}
    q = np.asarray(quat) / np.linalg.norm(quat)
    bodies["top"]["pose"] = {"position": [offset[0], offset[1], height + 1e-3 + _DROP_REACH * s_top + drop],
                             "orientation": [float(q[1]), float(q[2]), float(q[3]), float(q[0])]}
    bodies["top"]["twist"] = {"angular": list(spin)}
    return Simulator(load_scene({"gravity": [0.0, 0.0, -9.81], "ground": [{"normal": [0, 0, 1], "material": material}],
                                "bodies": bodies}), "rk4", dt, threads=1)


def test_a_can_held_on_its_rim_whose_held_step_would_throw_it_into_a_falling_can_lands_on_its_face():
    """A can (1 kg, r = 41 mm, 82 mm long) standing on the ground, a can (0.2 kg, r = 31 mm) spinning at (0, 2.5,
    1) rad/s dropped 31 mm onto it 35 mm off its axis (e = μ = 0.3, rk4 at dt = 10 ms; a case a random scan found):
    the lower can rocks on its rim, and in the step of their second meeting its held step, its holding force held
    over the piece, would throw it (K + U from 0.40 J to 2.3 J at the instant it would meet the upper). The pair's
    step has its end face land where it was instead, as the ground pass does, and the meeting found on that throw
    is not had: K + U of the two never rises above its start (1e-12 of it) over 0.2 s; the guard acted."""
    sim = _dropped_pair(("cylinder", "cylinder"), (0.041015625, 0.03125), (1.0, 0.2), 0.3, 0.3, 1e-2,
                        (0.03515625, 0.0), 0.03125, [0.0, 0.0, 0.0, 1.0], [0.0, 2.5, 1.0])
    _never_above_start(sim, np.array([1.0, 0.2]), 20)
    assert sim.contact.counts["face_landed"] >= 1


def test_a_can_lying_on_its_side_whose_held_step_would_throw_it_is_not_stood_on_its_end():
    """A can (0.2 kg, r = 30 mm) dropped 16 mm, tilted, onto a can (0.2 kg, r = 55 mm) standing on the ground
    (e = 0.3, μ = 0.8, rk4 at dt = 10 ms; a case a random scan found) rolls off it and comes to lie on its side on
    the ground (its centre its radius up, within 1e-4 m, at 0.5 s). Its slides stop within steps: located, they are no
    throw (held over the whole step at the friction of its start, it overshoot each stop, and was left at rest where
    it was, again and again). Only a can within a hair of upright has its end face land instead: this one is never
    stood on its end (that stood it 15 cm up, K + U from 0.17 J to 0.47 J). K + U of the two never rises above its
    start (1e-12 of it) over 0.5 s."""
    sim = _dropped_pair(("cylinder", "cylinder"), (0.0546875, 0.03), (0.2, 0.2), 0.3, 0.8, 1e-2, (0.0625, 0.0625),
                        0.015625, [-0.03125, -0.25, 1.0, 0.09375], [0.0, 1.0, 0.0])
    _never_above_start(sim, np.array([0.2, 0.2]), 50)
    assert sim.contact.counts["held_thrown"] == 0 and sim.contact.counts["face_landed"] == 0
    assert abs(sim.positions_world()[1, 2] - 0.03) <= 1e-4


def test_a_can_standing_on_its_end_whose_compiled_held_step_throws_it_lands_its_face():
    """A capsule (0.2 kg, r = 20 mm) dropped 3 mm, tilted and spinning, onto a can (1 kg, r = 75 mm, 151 mm long)
    standing on its end (e = μ = 0.3, rk4 at dt = 10 ms; a case a random scan found) rocks the can onto its rim. Its
    held steps are taken in the compiled pass and handed to the solver for the events in them (at 0.07 s), and are
    guarded as every held step is: a piece that would throw the can (raise its K + U by more than THROWN of it under
    gravity alone) has its end face land instead. K + U of the two never rises above its start (1e-12 of it) over
    1.2 s, and the face landed."""
    sim = _dropped_pair(("cylinder", "capsule"), (0.07539949411987433, 0.032825317808619345), (1.0, 0.2), 0.3, 0.3,
                        1e-2, (0.06873, 0.05951), 0.00296, [-0.0497, 0.9866, -0.169, -0.5999],
                        [1.9105, -1.2334, -1.2402])
    _never_above_start(sim, np.array([1.0, 0.2]), 120)
    assert sim.contact.counts["face_landed"] >= 1


def test_a_can_rocking_on_its_rim_whose_slide_stops_where_its_held_step_throws_it_lands_on_its_face():
    """A ball (0.2 kg, r = 39 mm) dropped 21 mm onto the edge of a can standing on the ground (5 kg, r = 78 mm;
    e = 0.7, μ = 0.3, rk4 at dt = 10 ms; a case the property test below found): the can rocks on its rim near
    upright, sliding. In its 11th step the slide's stop was located 6.02 ms in, where its held step (the rim's
    force found at every stage) was already throwing it: the step map's K + U rose from 3.84 J to 4.16 J there and
    to 8.2 J 9 µs later. Taken from that stop, the can flew off its face: K + U of the two rose 0.28 J above its
    start. A stop (or a wall's hit) located on a held step that threw the body is taken as a thrown step is: the
    can's end face lands where it was. K + U of the two never rises above its start (1e-12 of it) over 0.2 s."""
    sim = _dropped_pair(("cylinder", "sphere"), (0.078125, 0.0390625), (5.0, 0.2), 0.7, 0.3, 1e-2,
                        (0.078125, 0.0390625), 0.021484375, [0.0, 0.0, 0.0, 1.0], [0.0, 0.0, 0.0])
    _never_above_start(sim, np.array([5.0, 0.2]), 20)
    assert sim.contact.counts["face_landed"] >= 1


def test_a_can_whose_rim_piece_throws_it_goes_on_from_the_pieces_start():
    """The can and ball of the test above, the ball turned and spinning about the vertical at 1 rad/s, dropped
    21.7 mm (a case the property test below found): the can rocks on its rim. In its 11th step a piece of its held
    span on the rim (not the smallest: its rim turned slower than the pieces follow) raised its K + U from 3.84 J
    to 5.47 J, and the span went on from there: K + U of the two rose 1.1 J above its start. A piece that threw the
    can is taken from its start, as a held step that threw it is (its end face lands). K + U never rises above its
    start (1e-12 of it) over 0.3 s."""
    sim = _dropped_pair(("cylinder", "sphere"), (0.078125, 0.0390625), (5.0, 0.2), 0.7, 0.3, 1e-2,
                        (0.078125, 0.0390625), 0.021668982744449377, [0.5625, 0.0, 1.0, 0.25], [0.0, 0.0, 1.0])
    _never_above_start(sim, np.array([5.0, 0.2]), 30)
    assert sim.contact.counts["rim_pieces"] >= 1 and sim.contact.counts["face_landed"] >= 1


@pytest.mark.slow
@settings(max_examples=60, deadline=None)
@example(kinds=("cylinder", "sphere"), sizes=(0.078125, 0.0390625), masses=(5.0, 0.2), e=0.7, mu=0.3,
         dt=1e-2, offset=(0.078125, 0.0390625), drop=0.021484375, quat=[0.0, 0.0, 0.0, 1.0], spin=[0.0, 0.0, 0.0])
@example(kinds=("cylinder", "sphere"), sizes=(0.078125, 0.0390625), masses=(5.0, 0.2), e=0.7, mu=0.3,
         dt=1e-2, offset=(0.078125, 0.0390625), drop=0.021668982744449377, quat=[0.5625, 0.0, 1.0, 0.25],
         spin=[0.0, 0.0, 1.0])
@example(kinds=("cylinder", "capsule"), sizes=(0.07539949411987433, 0.032825317808619345), masses=(1.0, 0.2), e=0.3,
         mu=0.3, dt=1e-2, offset=(0.07103583662093957, 0.06240356168564353), drop=0.001,
         quat=[0.0, 1.0, -0.12479268146700018, -0.6139012753048182],
         spin=[2.333780328927162, -1.490698576417424, -1.490698576417424])
@example(kinds=("cylinder", "cylinder"), sizes=(0.0546875, 0.03), masses=(0.2, 0.2), e=0.3, mu=0.8, dt=1e-2,
         offset=(0.0625, 0.0625), drop=0.015625, quat=[-0.03125, -0.25, 1.0, 0.09375], spin=[0.0, 1.0, 0.0])
@example(kinds=("cylinder", "cylinder"), sizes=(0.041015625, 0.03125), masses=(1.0, 0.2), e=0.3, mu=0.3, dt=1e-2,
         offset=(0.03515625, 0.0), drop=0.03125, quat=[0.0, 0.0, 0.0, 1.0], spin=[0.0, 2.5, 1.0])
@example(kinds=("cylinder", "box"), sizes=(0.04, 0.03), masses=(5.0, 0.2), e=0.7, mu=0.0, dt=1e-2,
         offset=(0.0, 0.0234375), drop=0.04729514828667772, quat=[0.0, 1.0, 0.78125, 0.3046875], spin=[0.0, 1.0, 0.0])
@given(kinds=st.tuples(st.sampled_from(sorted(_KINDS)), st.sampled_from(sorted(_KINDS))),
       sizes=st.tuples(st.floats(0.04, 0.1), st.floats(0.03, 0.08)),
       masses=st.tuples(st.sampled_from([0.2, 1.0, 5.0]), st.sampled_from([0.2, 1.0, 5.0])),
       e=st.sampled_from([0.0, 0.3, 0.7]), mu=st.sampled_from([0.0, 0.3, 0.8]), dt=st.sampled_from([1e-3, 1e-2]),
       offset=st.tuples(st.floats(0.0, 0.1), st.floats(0.0, 0.1)), drop=st.floats(1e-3, 5e-2),
       quat=st.lists(_unit, min_size=4, max_size=4).filter(lambda q: np.linalg.norm(q) > 0.1),
       spin=st.lists(st.floats(-3.0, 3.0), min_size=3, max_size=3))
def test_energy_never_rises_when_a_body_drops_onto_one_resting_on_the_ground(kinds, sizes, masses, e, mu, dt, offset,
                                                                            drop, quat, spin):
    """Any shape dropped, turned and spinning, onto any shape resting on the ground (a capsule lying), off its axis,
    with any of the materials and steps, rk4 for 2 s: impacts, rocking, rolling off, resting in an island. The energy
    K + U of the two never rises above its start (1e-12 of it): contact passes energy on and takes it out, never adds
    it. (The random scan this property comes from found gains of up to 2574 J before the pieces and the islands'
    inelastic step at a step's start.)"""
    sim = _dropped_pair(kinds, sizes, masses, e, mu, dt, offset, drop, quat, spin)
    _never_above_start(sim, np.array(masses), int(round(2.0 / dt)))


def test_a_box_sliding_on_the_ground_into_a_resting_box_pushes_it_on():
    """A cube (1 kg, 0.1 m) sliding frictionless on the ground at 1 m/s into a resting one 0.5 mm
    ahead, e = 0: they meet at 0.5 ms inside the first step (neither in flight, every pair then
    touching: the step's event search has nothing left to advance to) and go on together at
    0.5 m/s (momentum): positions 0.0005 + 0.5 (t − 0.0005) and 0.1005 + 0.5 (t − 0.0005), 1e-9."""
    box = {"box": [0.1, 0.1, 0.1]}
    slick = {"restitution": 0.0, "friction": 0.0}
    bodies = {name: {"mass": 1.0, "inertia": box, "collision": box, "material": slick,
                     "pose": {"position": [x, 0.0, 0.05]}, "twist": {"linear": [v, 0.0, 0.0]}}
              for name, x, v in (("a", 0.0, 1.0), ("b", 0.1005, 0.0))}
    sim = Simulator(load_scene({"gravity": [0.0, 0.0, -9.81], "bodies": bodies,
                                "ground": [{"normal": [0, 0, 1], "offset": 0.0, "material": slick}]}), "rk4", 1e-3)
    sim.step(5)
    t = 5e-3
    np.testing.assert_allclose(sim.linear_velocities_world()[:, 0], [0.5, 0.5], rtol=0, atol=1e-9)
    np.testing.assert_allclose(sim.positions_world()[:, 0], [0.0005 + 0.5 * (t - 0.0005), 0.1005 + 0.5 * (t - 0.0005)],
                               rtol=0, atol=1e-9)


def test_a_ball_sliding_into_a_ball_lifting_off_the_ground_strikes_it():
    """A ball (5 cm, 1 kg) sliding frictionless on the ground at 3 m/s toward one 1 mm ahead that lifts off it at
    0.1 m/s (in flight from the start, touching its ground): they meet inside the first step (dt = 1 ms), an
    impact naming both, and never overlap (signed distance ≥ −1e-9 m at every step); momentum along the ground is
    kept (every contact frictionless, the ground's normal vertical: 1e-12 relative) and K + U never rises."""
    r, slick = 0.05, {"restitution": 0.0, "friction": 0.0}
    ball = {"sphere": r}
    bodies = {name: {"mass": 1.0, "inertia": ball, "collision": ball, "material": slick,
                     "pose": {"position": [x, 0.0, r]}, "twist": {"linear": v}}
              for name, x, v in (("a", 0.0, [3.0, 0.0, 0.0]), ("b", 2.0 * r + 1e-3, [0.0, 0.0, 0.1]))}
    sim = Simulator(load_scene({"gravity": [0.0, 0.0, -9.81], "bodies": bodies,
                                "ground": [{"normal": [0, 0, 1], "material": slick}]}), "rk4", 1e-3, threads=1)
    masses = np.ones(2)

    def energy():
        return _energy(sim) + 9.81 * float(masses @ sim.state.p_WC_W[:, 2])

    start = energy()
    for _ in range(5):
        sim.step()
        rows = sim.state.rows()
        assert sim.contact.pairs.contact(rows[0], 0, rows[1], 1) >= -1e-9
        assert energy() <= start + 1e-12 * start
        assert float(masses @ sim.linear_velocities_world()[:, 0]) == pytest.approx(3.0, rel=1e-12)
    assert [e.other for e in sim.contact.events_of("a", "impact")] == ["b"]


def _cubes_toward_a_wall(cubes: dict, wall_face: float) -> Simulator:
    """Cubes (0.1 m, 1 kg; name: (x, speed along +x)) on a frictionless ground, a static wall whose face is at x =
    wall_face, e = 0 everywhere, rk4 at dt = 1 ms."""
    box, wall = {"box": [0.1, 0.1, 0.1]}, {"box": [0.1, 1.0, 1.0]}
    slick = {"restitution": 0.0, "friction": 0.0}
    bodies = {name: {"mass": 1.0, "inertia": box, "collision": box, "material": slick,
                     "pose": {"position": [x, 0.0, 0.05]}, "twist": {"linear": [v, 0.0, 0.0]}}
              for name, (x, v) in cubes.items()}
    bodies["wall"] = {"motion": "static", "mass": 1.0, "inertia": wall, "collision": wall, "material": slick,
                      "pose": {"position": [wall_face + 0.05, 0.0, 0.5]}}
    return Simulator(load_scene({"gravity": [0.0, 0.0, -9.81], "bodies": bodies,
                                 "ground": [{"normal": [0, 0, 1], "material": slick}]}), "rk4", 1e-3, threads=1)


def _stay(sim: Simulator, x: list) -> None:
    """Five steps, at the end of each the cubes at rest at x (m), within 1e-9."""
    for _ in range(5):
        sim.step()
        np.testing.assert_allclose(sim.linear_velocities_world()[:2], 0.0, rtol=0, atol=1e-9)
        np.testing.assert_allclose(sim.positions_world()[:2, 0], x, rtol=0, atol=1e-9)


def test_a_box_sliding_into_a_box_against_a_wall_stops():
    """A cube sliding at 1 m/s into a resting one 0.5 mm ahead whose far face touches a static wall: they meet at
    0.5 ms inside the first step, the wall takes the blow (the pair's impact and the wall's, round after round at
    that instant) and both stop there: at the end of every step, positions 0.0005 and 0.1005 m, speeds 0."""
    _stay(_cubes_toward_a_wall({"a": (0.0, 1.0), "b": (0.1005, 0.0)}, 0.1505), [0.0005, 0.1005])


def test_a_box_sliding_into_a_wall_is_struck_there_by_a_faster_one_behind_it():
    """Toward a static wall, the front cube at 1 m/s, its far face 0.3 mm from the wall; the one behind at 2 m/s,
    0.5 mm behind it. The front one stops against the wall at 0.3 ms, the other meets it at 0.4 ms (0.2 mm left,
    closing at 2 m/s) and stops there too (the wall takes the blow): at every step's end the front one at
    0.1008 m, the other at 0.0008 m, both at rest."""
    _stay(_cubes_toward_a_wall({"behind": (0.0, 2.0), "front": (0.1005, 1.0)}, 0.1508), [0.0008, 0.1008])


def test_a_box_lies_on_a_box_and_a_ball_on_both():
    """Boxes stacked on the ground (the upper dropped 0.2 m, e = 0) and a ball dropped off-centre onto
    them: nothing passes through anything, and the stack comes to rest exactly where it stands.

    Bodies in contact with each other are stepped together (island.py): the landings are inelastic
    velocity steps (first order), the resting contact is the sticking case solved exactly, and
    every point deeper than PROJECT_TOL × the pair's size (1e-12 m per m) after a step is projected
    out. Checked at every step: the box on the ground never below it, each pair's signed distance
    ≥ −1e-12 m; at the end (0.6 s: both land at 0.2 s) the heights of a box on a box (0.3 m) and
    a ball on it (0.45 m) within 1e-12 m, and every speed ≤ 1e-9.
    """
    h = 1e-3
    bodies = {
        "low": {"mass": 2.0, "inertia": {"box": [0.4, 0.4, 0.2]}, "material": {"restitution": 0.0, "friction": 0.5},
                "pose": {"position": [0.0, 0.0, 0.1]}},
        "high": {"mass": 1.0, "inertia": {"box": [0.3, 0.3, 0.2]}, "pose": {"position": [0.0, 0.0, 0.5]}},
        "ball": {"mass": 0.5, "inertia": {"sphere": 0.05}, "pose": {"position": [0.02, 0.01, 0.65]}},
    }
    sim = Simulator(load_scene({"gravity": [0.0, 0.0, -9.81], "ground": [{"normal": [0, 0, 1]}], "bodies": bodies}),
                    "rk4", h)
    pairs = sim.contact.pairs
    for _ in range(600):
        sim.step()
        rows = sim.state.rows()
        assert sim.state.p_WC_W[0, 2] >= 0.1 - 1e-12
        assert pairs.contact(rows[0], 0, rows[1], 1) >= -1e-12
        assert pairs.contact(rows[1], 1, rows[2], 2) >= -1e-12
    assert all(sim.contact.in_island(name) for name in bodies)
    z = sim.state.p_WC_W[:, 2]
    assert z[1] == pytest.approx(0.3, abs=1e-12) and z[2] == pytest.approx(0.45, abs=1e-12)
    assert abs(sim.state.v_WC_W).max() <= 1e-9 and abs(sim.state.w_WP_P).max() <= 1e-9


def test_one_moving_body_has_no_body_body_pass():
    bodies = {"ball": _ball(0.1, 1.0, [0.0, 0.0, 1.0], [0.0, 0.0, 0.0])}
    sim = Simulator(load_scene({"gravity": [0.0, 0.0, -9.81], "ground": [{"normal": [0, 0, 1]}], "bodies": bodies}),
                    "rk4", 1e-3)
    assert sim.contact.pairs is None
    bodies["other"] = _ball(0.1, 1.0, [1.0, 0.0, 1.0], [0.0, 0.0, 0.0])
    sim = Simulator(load_scene({"gravity": [0.0, 0.0, -9.81], "ground": [{"normal": [0, 0, 1]}], "bodies": bodies}),
                    "rk4", 1e-3)
    assert isinstance(sim.contact.pairs, BodyPairs)


def test_two_held_bodies_slid_apart_do_not_slide_one_into_a_wall() -> None:
    """A frictionless can (r = 97 mm, 96 mm tall) standing in the corner of a bin (walls' inner faces at x = 0.6 m
    and y = −0.6 m), touching both walls and spinning about its axis, and a frictionless capsule lying on the floor
    sliding into it at 0.63 m/s (a state a mixed pile left them in; semi-implicit Euler, dt = 5 ms, tolerance 10 µm).
    The group's step ends with the two overlapping, both held: each is slid out within its ground's plane, the can
    along the crease of the floor and the wall it is held on. That slid it 65.5 µm into the other wall. Now a body
    the slide would put into a wall stays and the other takes the whole move: over 5 steps the can is never inside
    a wall by more than the tolerance (from its axis and radius), nor the two bodies inside each other by more."""
    def placed(shape, mass, inertia, position, orientation, linear, angular):
        return {"mass": mass, "inertia": inertia, "collision": shape, "material": {"restitution": 0.0, "friction": 0.0},
                "pose": {"position": position, "orientation": orientation},
                "twist": {"linear": linear, "angular": angular}}
    capsule = placed({"capsule": [0.05458480832431028, 0.09755841457634706]}, 2.4561102221421134,
                     {"cylinder": [0.05458480832431028, 0.20672803122496763]},
                     [0.39638173382582276, -0.3945931269039142, 0.05458480832431028],
                     [-0.6807936159639284, -0.1911022042331254, 0.6213721355788531, -0.3374858058143714],
                     [0.6206878551833082, 0.1075183561561409, 0.0], [0.7968158577167985, 0.7745289236720758,
                                                                      -6.732984652844952])
    radius, length = 0.0965962542208107, 0.09552274987602226
    can = placed({"cylinder": [radius, length]}, 2.110461964921587, {"cylinder": [radius, length]},
                 [0.503403745757994, -0.5034037457791843, 0.04776137493801113],
                 [1.5559111401044215e-17, -1.19142127331741e-19, 0.8885082053413005, 0.4588607294606737],
                 [-3.5784437990016286e-11, 3.798948141406175e-14, 0.0], [0.0, 0.0, 2.2848632292392095])
    scene = {"gravity": [0.0, 0.0, -9.81], "bodies": {"capsule": capsule, "can": can, **bin_walls(1.2)},
             "ground": [{"normal": [0, 0, 1], "material": {"restitution": 0.0, "friction": 0.6}}]}
    tolerance = 1e-5
    sim = Simulator(load_scene(scene), "semi_implicit_euler", 5e-3, threads=1)
    sim.contact.penetration_tolerance = tolerance
    sim.contact.sleeping = True
    moving = np.array([True, True, False, False, False, False])
    for _ in range(5):
        sim.step()
        axis = quat_rotate(np.roll(sim.orientations_xyzw()[1], 1), np.array([0.0, 0.0, 1.0]))
        centre = sim.positions_world()[1]  # the can's deepest reach into each wall: its rim's, tilted
        assert centre[0] + abs(axis[0]) * length / 2 + radius * math.hypot(axis[1], axis[2]) - 0.6 <= tolerance + 1e-9
        assert -0.6 - (centre[1] - abs(axis[1]) * length / 2 - radius * math.hypot(axis[0], axis[2])) <= tolerance + 1e-9
        for a, b, depth in overlapping_bodies(sim.positions_world(), sim.orientations_xyzw()[:, [3, 0, 1, 2]],
                                              sim.contact.shapes, moving):
            assert depth <= tolerance + 1e-9, (a, b, depth)
    assert sim.contact.pairs.separations >= 1


#: A box (0.2 × 0.15 × 0.1 m, 2.18 kg, e = 0, μ = 1.2) spinning at 253 rad/s and a capsule (r 5 cm, 20 cm long,
#: 0.455 kg, e = 0.3, μ = 0.6) spinning at 59 rad/s beside the bin's wall at x = 0.8 m, from a random run: their state
#: rows (p, q (w, x, y, z), v, ω in their principal axes).
BOX_SPUN = (0.6184493815544109, -0.05599588698211271, 0.1270497644599279, 0.9807579832319067, 9.714954187169262e-05,
            0.19519582405945435, 0.0035155595003186907, 11.031142565415022, -1.1517486887891883, 14.739416552223654,
            -32.9890409961955, 251.21503715115125, 15.071600168653688)
CAPSULE_AT_THE_WALL = (0.7499967305599597, -0.026668105548708576, 0.051191443709031136, 0.7005150815064608,
                       0.7005467683123745, 0.09622390946753363, -0.0961967007535534, -0.01194195543507933,
                       0.010635050544554908, -0.8591925246015218, 18.73843857592701, 5.382666940792466,
                       55.51286345453848)


@pytest.mark.parametrize("integrator", ["rk4", "semi_implicit_euler"])
def test_a_capsule_spinning_against_a_wall_in_a_group_step_ends_its_zeno_sequence(integrator):
    """The capsule, struck by the box within the step, then strikes the wall again and again, each rebound a quarter
    of the last (its spin turns its rim back into the wall): the group's step raised RuntimeError after 10,000
    events. After ZENO_IMPACTS impacts against fixed geometry in a group's step it rests where the last one left
    it, as on the ground pass. Over 30 steps at dt = 1 ms: no plane struck more than ZENO_IMPACTS times in a step,
    every state finite, the capsule never through the wall's face, and with rk4 K + U never above its lowest earlier
    value by more than 1e-9 of it (its own error on the box's spin of 0.25 rad a step: 2e-10 was seen; semi-implicit
    Euler's explicit spin adds 0.03 J a step to the box flying free after the events)."""
    bodies = dict(bin_walls(1.6))
    bodies["box"] = {"mass": 2.177801367808881, "inertia": {"box": [0.2, 0.15, 0.1]},
                     "material": {"restitution": 0.0, "friction": 1.2}, "pose": {"position": [0.0, 0.0, 0.5]}}
    bodies["pill"] = {"mass": 0.4549939537164044, "inertia": {"cylinder": [0.05, 0.3]},
                      "collision": {"capsule": [0.05, 0.2]}, "material": {"restitution": 0.3, "friction": 0.6},
                      "pose": {"position": [0.0, 0.4, 0.5]}}
    sim = Simulator(load_scene({"gravity": [0.0, 0.0, -9.81], "bodies": bodies,
                                "ground": [{"normal": [0, 0, 1], "offset": 0.0,
                                            "material": {"restitution": 0.0, "friction": 0.5}}]}),
                    integrator=integrator, dt=1e-3)
    for name, row in (("box", BOX_SPUN), ("pill", CAPSULE_AT_THE_WALL)):
        q_WP = np.array(row[3:7])
        sim.set_body_state(name, position_world=row[0:3], orientation_xyzw=[*q_WP[1:], q_WP[0]],
                           linear_velocity_world=row[7:10], angular_velocity_world=quat_rotate(q_WP, np.array(row[10:13])))
    sim.contact.reset(sim)
    sim.contact.sleeping = True
    pill, events = sim.body_names.index("pill"), sim.contact.events

    def energy():
        return float((sim.kinetic_energy() + sim.potential_energy())[[pill - 1, pill]].sum())

    lowest = energy()
    for _ in range(30):
        seen = len(events)
        sim.step()
        struck = [e.ground for e in events[seen:] if e.body == "pill" and e.kind == "impact" and not e.other]
        assert all(struck.count(j) <= ZENO_IMPACTS for j in set(struck))
        assert np.isfinite(sim.state.rows()).all()
        axis = quat_rotate(sim.state.q_WP[pill], np.array([0.0, 0.0, 1.0]))
        assert sim.state.p_WC_W[pill, 0] + 0.1 * abs(axis[0]) + 0.05 <= 0.8 + 1e-12
        assert integrator != "rk4" or energy() <= lowest + 1e-9 * abs(lowest)
        lowest = min(lowest, energy())
    assert sim.contact.events_of("pill", "rest")


@pytest.mark.parametrize("e", [0.0, 0.5])
@pytest.mark.parametrize("integrator", ["rk4", "semi_implicit_euler"])
def test_a_crate_asleep_set_moving_into_the_ground_as_a_ball_strikes_it_is_struck_by_the_ground(integrator, e):
    """A crate (1 kg) asleep on the ground, its velocity set to 2 m/s into it as a ball (0.5 kg, 3 m/s) strikes it
    within the step: the ground's impact law acts at the step's start (e on both), then the pair's. It was held by
    the force it fell asleep with, not struck, and sank 1.4 cm (e = 0); woken in the group's step, touching, it
    rested there without an impact (its restitution lost). Over 5 steps no point of it is below the ground by more
    than 1e-12 m."""
    box = {"box": [0.2, 0.15, 0.1]}
    material = {"restitution": e, "friction": 0.5}
    sim = Simulator(load_scene({"gravity": [0.0, 0.0, -9.81], "bodies": {
        "crate": {"mass": 1.0, "inertia": box, "material": material, "pose": {"position": [0.0, 0.0, 0.05]}},
        "ball": _ball(0.05, 0.5, [0.5, 0.0, 0.05], [0.0, 0.0, 0.0])},
        "ground": [{"normal": [0, 0, 1], "offset": 0.0, "material": material}]}), integrator=integrator, dt=1e-2)
    sim.contact.sleeping = True
    sim.step(3)
    assert sim.contact.pairs.islands.asleep[:2].all()
    sim.set_body_state("ball", position_world=[0.17, 0.0, 0.05], linear_velocity_world=[-3.0, 0.0, 0.0])
    sim.set_body_state("crate", linear_velocity_world=[0.0, 0.0, -2.0])
    t0 = sim.time
    contact = sim.contact
    sim.step()
    struck = [event for event in contact.events_of("crate", "impact") if not event.other]
    assert struck and struck[0].time == t0
    assert struck[0].normal_speed_before == pytest.approx(-2.0, rel=1e-12)
    assert struck[0].normal_speed_after == pytest.approx(2.0 * e, abs=1e-12)
    assert contact.events_of("crate", "impact")[1].other == "ball"
    for _ in range(5):
        corners = [quat_rotate(sim.state.q_WP[0], np.array([sx * 0.1, sy * 0.075, sz * 0.05]))
                   for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]
        assert sim.state.p_WC_W[0, 2] + min(c[2] for c in corners) >= -1e-12
        sim.step()
