"""No tunnelling: a small fast body meets a thin one even when the whole passage lies inside one step.

A sphere of diameter 1 cm at 100 m/s moves 1 m in a step of 10 ms, a hundred times its own size:
at both ends of the step it is clear of a 1 cm thick wall it passes. The swept broad phase and the
conservative advancement of core/contact/body_pairs.py find the passage and the impact is located
at its closed-form time (straight lines, no gravity: the root of a linear gap), within 1e-9
relative, with Newton's rebound −e v along the normal (frictionless).

* against a static box 1 cm thick (static_geometry.py), face on and at a slant (a glancing hit
  on its face), sliding on the ground into it, from apart or touching it (held on the ground: the ground pass
  looks along its step), flying along the face of another static box into it, and thrown through it from rest
  against it;
* two such spheres flying at each other (relative speed 200 m/s): equal masses, e = 0.5, the
  textbook v_a' = ((m_a − e m_b) v_a + (1 + e) m_b v_b)/(m_a + m_b);
* one sphere flying past the wall's edge with a 1 mm gap: no impact (the broad phase looks, the
  narrow phase finds it apart all along).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from rigid_body_sim.core import Simulator, load_scene
from rigid_body_sim.core.kernels.contact.layout import GROUND_WIDTH

NO_HALF_SPACES = np.zeros((0, GROUND_WIDTH))  # spheres_may_meet's half-space rows: none

R, V, DT, E = 0.005, 100.0, 10e-3, 0.5
WALL_X, HALF_T = 0.5, 0.005  # the wall's centre (m) and half thickness (m)


def _sphere(position, velocity, e=E, mu=0.0):
    return {"mass": 0.01, "inertia": {"sphere": R}, "material": {"restitution": e, "friction": mu},
            "pose": {"position": list(position)}, "twist": {"linear": list(velocity)}}


def _wall(material=None):
    wall = {"mass": 1.0, "inertia": {"box": [2 * HALF_T, 1.0, 1.0]}, "motion": "static",
            "pose": {"position": [WALL_X, 0.0, 0.0]}}
    if material:
        wall["material"] = material
    return wall


@pytest.mark.parametrize("angle_deg", [0.0, 30.0])
def test_a_fast_small_sphere_does_not_pass_through_a_thin_static_box(angle_deg):
    a = math.radians(angle_deg)
    v = np.array([V * math.cos(a), V * math.sin(a), 0.0])
    start = np.array([0.0, -0.2, 0.0])
    scene = load_scene({"gravity": [0.0, 0.0, 0.0], "ground": [],
                        "bodies": {"wall": _wall({"restitution": E, "friction": 0.0}), "ball": _sphere(start, v)}})
    sim = Simulator(scene, "rk4", DT)
    sim.step(3)
    impacts = sim.contact.events_of("ball", "impact")
    assert len(impacts) == 1
    t_hit = (WALL_X - HALF_T - R - start[0]) / v[0]
    assert impacts[0].time == pytest.approx(t_hit, rel=1e-9)
    v_after = np.array([-E * v[0], v[1], 0.0])
    np.testing.assert_allclose(sim.state.v_WC_W[1], v_after, rtol=0.0, atol=1e-9 * V)
    assert sim.state.p_WC_W[1, 0] < WALL_X - HALF_T - R  # still on its side
    x = start + v * t_hit + v_after * (sim.time - t_hit)
    np.testing.assert_allclose(sim.state.p_WC_W[1], x, rtol=0.0, atol=1e-9)


@pytest.mark.parametrize("x0", [0.0, WALL_X - HALF_T - R])
@pytest.mark.parametrize("integrator", ["rk4", "semi_implicit_euler"])
def test_a_fast_small_sphere_sliding_on_the_ground_does_not_pass_through_a_thin_static_box(integrator, x0):
    """The sphere at rest on frictionless ground (held on it, g = 9.81), apart from the wall or touching it, then
    set moving at 100 m/s along the ground toward it: apart from it at both ends of the step, it strikes it inside
    the step (it passed through before), at the closed-form time (at once when touching), and rebounds at −e v
    along the ground, still on it."""
    ground = {"restitution": 0.0, "friction": 0.0}
    start = np.array([x0, 0.0, R])
    scene = load_scene({"gravity": [0.0, 0.0, -9.81], "ground": [{"normal": [0, 0, 1], "offset": 0.0,
                                                                   "material": ground}],
                        "bodies": {"wall": _wall({"restitution": E, "friction": 0.0}),
                                   "ball": _sphere(start, [0.0, 0.0, 0.0])}})
    sim = Simulator(scene, integrator, DT)
    sim.step(2)
    assert sim.contact.is_resting("ball")
    sim.set_body_state("ball", linear_velocity_world=[V, 0.0, 0.0])
    t0 = sim.time
    sim.step(1)
    impacts = sim.contact.events_of("ball", "impact")
    assert len(impacts) == 1 and sim.contact.static_body_of(impacts[0].ground) == "wall"
    t_hit = (WALL_X - HALF_T - R - x0) / V
    assert impacts[0].time - t0 == pytest.approx(t_hit, rel=1e-9, abs=1e-15)
    np.testing.assert_allclose(sim.state.v_WC_W[1], [-E * V, 0.0, 0.0], rtol=0.0, atol=1e-9 * V)
    x = WALL_X - HALF_T - R - E * V * (DT - t_hit)
    np.testing.assert_allclose(sim.state.p_WC_W[1], [x, 0.0, R], rtol=0.0, atol=1e-9)
    assert sim.contact.is_resting("ball")


@pytest.mark.parametrize("integrator", ["rk4", "semi_implicit_euler"])
def test_a_fast_small_sphere_flying_along_one_wall_does_not_pass_through_another(integrator):
    """The sphere flies at 100 m/s touching the face of a first wall (no gravity), along it into the thin one across
    its path: touching one static shape, its path is still followed against the others (it passed through before),
    and it strikes the second at the closed-form time, rebounding at −e v."""
    first = {"mass": 1.0, "inertia": {"box": [0.79, 0.01, 1.0]}, "motion": "static",
             "pose": {"position": [0.095, -0.005, 0.0]}, "material": {"restitution": E, "friction": 0.0}}
    scene = load_scene({"gravity": [0.0, 0.0, 0.0], "ground": [],
                        "bodies": {"first": first, "wall": _wall({"restitution": E, "friction": 0.0}),
                                   "ball": _sphere([0.0, R, 0.0], [V, 0.0, 0.0])}})
    sim = Simulator(scene, integrator, DT)
    sim.step(1)
    impacts = sim.contact.events_of("ball", "impact")
    assert len(impacts) == 1 and sim.contact.static_body_of(impacts[0].ground) == "wall"
    t_hit = (WALL_X - HALF_T - R) / V
    assert impacts[0].time == pytest.approx(t_hit, rel=1e-9)
    np.testing.assert_allclose(sim.state.v_WC_W[2], [-E * V, 0.0, 0.0], rtol=0.0, atol=1e-9 * V)
    x = WALL_X - HALF_T - R - E * V * (DT - t_hit)
    np.testing.assert_allclose(sim.state.p_WC_W[2], [x, R, 0.0], rtol=0.0, atol=1e-9)


@pytest.mark.parametrize("integrator", ["rk4", "semi_implicit_euler"])
def test_a_small_sphere_at_rest_against_a_thin_static_box_thrown_through_it_strikes_it(integrator):
    """The sphere at rest on the ground (g = 9.81) touching the wall's face, set moving at 100 m/s into it and 10 m/s
    up: it lifts off the ground, and is struck by the wall at once (its lowest plane is the ground, which it leaves;
    it moves into the wall it touches as well), rebounding at −e v; it went through before."""
    ground = {"restitution": 0.0, "friction": 0.0}
    x0 = WALL_X - HALF_T - R
    scene = load_scene({"gravity": [0.0, 0.0, -9.81], "ground": [{"normal": [0, 0, 1], "offset": 0.0,
                                                                   "material": ground}],
                        "bodies": {"wall": _wall({"restitution": E, "friction": 0.0}),
                                   "ball": _sphere([x0, 0.0, R], [0.0, 0.0, 0.0])}})
    sim = Simulator(scene, integrator, DT)
    sim.step(2)
    assert sim.contact.is_resting("ball")
    up = 10.0
    sim.set_body_state("ball", linear_velocity_world=[V, 0.0, up])
    t0 = sim.time
    sim.step(1)
    impacts = sim.contact.events_of("ball", "impact")
    assert len(impacts) == 1 and sim.contact.static_body_of(impacts[0].ground) == "wall"
    assert impacts[0].time == pytest.approx(t0, abs=1e-15)
    v_z = up - 9.81 * DT  # exact for a constant force, either method
    np.testing.assert_allclose(sim.state.v_WC_W[1], [-E * V, 0.0, v_z], rtol=0.0, atol=1e-9 * V)
    assert sim.state.p_WC_W[1, 0] == pytest.approx(x0 - E * V * DT, abs=1e-9)


@pytest.mark.parametrize("integrator", ["rk4", "semi_implicit_euler"])
def test_a_small_sphere_at_rest_against_a_thin_static_box_thrown_down_through_it_strikes_both(integrator):
    """The sphere at rest on the ground (g = 9.81, e = 0.5) touching the wall's face, set moving at 100 m/s into the
    wall and 10 m/s down: struck by the ground first (its lowest plane, which it moves into), then, at the same
    instant, by the wall it still touches and moves into: (−e V, 0, e·10 − g h) after the step (frictionless). Once
    struck by the ground it was not looked at against the wall and went through it."""
    mat = {"restitution": E, "friction": 0.0}
    x0 = WALL_X - HALF_T - R
    scene = load_scene({"gravity": [0.0, 0.0, -9.81], "ground": [{"normal": [0, 0, 1], "offset": 0.0,
                                                                   "material": mat}],
                        "bodies": {"wall": _wall(mat), "ball": _sphere([x0, 0.0, R], [0.0, 0.0, 0.0])}})
    sim = Simulator(scene, integrator, DT)
    sim.step(2)
    assert sim.contact.is_resting("ball")
    down = 10.0
    sim.set_body_state("ball", linear_velocity_world=[V, 0.0, -down])
    t0 = sim.time
    sim.step(1)
    impacts = sim.contact.events_of("ball", "impact")
    assert [sim.contact.static_body_of(e.ground) for e in impacts] == [None, "wall"]
    assert [e.time for e in impacts] == pytest.approx([t0, t0], abs=1e-15)
    np.testing.assert_allclose(sim.state.v_WC_W[1], [-E * V, 0.0, E * down - 9.81 * DT], rtol=0.0, atol=1e-9 * V)
    assert sim.state.p_WC_W[1, 0] == pytest.approx(x0 - E * V * DT, abs=1e-9)


@pytest.mark.parametrize("integrator", ["rk4", "semi_implicit_euler"])
def test_a_box_at_rest_thrown_down_and_at_a_thin_static_box_strikes_it(integrator):
    """A cube (0.1 m) at rest on frictionless ground (e = 0), 1 mm from the wall (e = 0, 1 cm thick), set moving at
    20 m/s toward it and 5 m/s down: struck onto the ground at once (it rests there), then it slides 1 mm into the
    wall, struck at t0 + 1 mm / 20 m/s, and stays at its face. Struck onto its ground in the step of the group its
    screen against the wall made (the wall no member of it), it slid on through the wall."""
    half, gap, speed = 0.05, 1e-3, 20.0
    x0 = WALL_X - HALF_T - half - gap
    mat = {"restitution": 0.0, "friction": 0.0}
    cube = {"mass": 1.0, "inertia": {"box": [2 * half] * 3}, "material": mat, "pose": {"position": [x0, 0.0, half]}}
    scene = load_scene({"gravity": [0.0, 0.0, -9.81], "ground": [{"normal": [0, 0, 1], "offset": 0.0, "material": mat}],
                        "bodies": {"wall": _wall(mat), "cube": cube}})
    sim = Simulator(scene, integrator, DT)
    sim.step(2)
    assert sim.contact.is_resting("cube")
    sim.set_body_state("cube", linear_velocity_world=[speed, 0.0, -5.0])
    t0 = sim.time
    sim.step(1)
    impacts = sim.contact.events_of("cube", "impact")
    assert [sim.contact.static_body_of(e.ground) for e in impacts] == [None, "wall"]
    assert impacts[1].time == pytest.approx(t0 + gap / speed, rel=1e-9)
    np.testing.assert_allclose(sim.state.p_WC_W[1], [x0 + gap, 0.0, half], rtol=0.0, atol=1e-9)
    np.testing.assert_allclose(sim.state.v_WC_W[1], [0.0, 0.0, 0.0], rtol=0.0, atol=1e-9)


def test_two_fast_small_spheres_meet_inside_one_step():
    scene = load_scene({"gravity": [0.0, 0.0, 0.0], "ground": [],
                        "bodies": {"a": _sphere([0.0, 0.0, 0.0], [V, 0.0, 0.0]),
                                   "b": _sphere([0.5, 0.0, 0.0], [-V, 0.0, 0.0])}})
    sim = Simulator(scene, "rk4", DT)
    sim.step(1)
    impacts = sim.contact.events_of("a", "impact")
    assert len(impacts) == 1 and impacts[0].other == "b"
    assert impacts[0].time == pytest.approx((0.5 - 2 * R) / (2 * V), rel=1e-9)
    m = 0.01
    va = ((m - E * m) * V + (1 + E) * m * -V) / (2 * m)
    vb = ((m - E * m) * -V + (1 + E) * m * V) / (2 * m)
    np.testing.assert_allclose(sim.state.v_WC_W[:, 0], [va, vb], rtol=0.0, atol=1e-9 * V)
    assert sim.state.p_WC_W[0, 0] < sim.state.p_WC_W[1, 0]  # not through each other


def test_a_fast_sphere_passing_the_wall_edge_is_not_stopped():
    start = [0.0, 0.5 + R + 1e-3, 0.0]  # 1 mm beside the wall's edge at y = 0.5
    scene = load_scene({"gravity": [0.0, 0.0, 0.0], "ground": [],
                        "bodies": {"wall": _wall(), "ball": _sphere(start, [V, 0.0, 0.0])}})
    sim = Simulator(scene, "rk4", DT)
    sim.step(2)
    assert not sim.contact.events
    np.testing.assert_allclose(sim.state.p_WC_W[1], [2 * DT * V, start[1], 0.0], rtol=0.0, atol=1e-12)


def test_swept_grid_finds_every_overlapping_pair_once():
    """The hashed grid of kernels/contact/swept.py against the brute force over random boxes (the
    definition: overlap on all three axes), with movable members and fixed ones up to 20 times
    larger (static shapes: tested against every movable one, outside the grid)."""
    from rigid_body_sim.core.kernels.contact.swept import grid_swept_pairs

    rng = np.random.default_rng(0)
    for n in (2, 30, 400):
        centre = rng.uniform(-1.0, 1.0, (n, 3)) * n ** (1 / 3) * 0.3
        half = rng.uniform(0.02, 0.2, (n, 3))
        lo, hi = centre - half, centre + half
        movable = rng.random(n) < 0.7
        half[~movable] *= rng.uniform(1.0, 20.0, (int((~movable).sum()), 1))  # fixed ones of any size
        lo, hi = centre - half, centre + half
        pairs = np.empty((n * n, 2), dtype=np.int64)
        heads = np.empty(1 << (2 * n - 1).bit_length(), dtype=np.int64)
        found = grid_swept_pairs(lo, hi, movable, np.empty((n, 3), dtype=np.int64), heads,
                                 np.empty(n, dtype=np.int64), pairs)
        brute = {(i, j) for i in range(n) for j in range(i + 1, n)
                 if (movable[i] or movable[j]) and np.all(lo[j] <= hi[i]) and np.all(lo[i] <= hi[j])}
        got = [tuple(p) for p in pairs[:found].tolist()]
        assert len(got) == len(set(got)) == found
        assert set(got) == brute


def test_swept_grid_query_finds_every_box_a_box_meets():
    """grid_overlaps (kernels/contact/swept.py: the islands' second look, _late_pairs) against the brute force: for
    query boxes from a tenth of a cell to wider than the grid holds, every member's box within the slack of the
    query's (all three axes) is found once, movable ones through the grid grid_swept_pairs left, fixed ones each."""
    from rigid_body_sim.core.kernels.contact.swept import grid_overlaps, grid_swept_pairs

    rng = np.random.default_rng(3)
    for n in (2, 30, 400):
        centre = rng.uniform(-1.0, 1.0, (n, 3)) * n ** (1 / 3) * 0.3
        half = rng.uniform(0.02, 0.2, (n, 3))
        movable = rng.random(n) < 0.7
        half[~movable] *= rng.uniform(1.0, 20.0, (int((~movable).sum()), 1))
        lo, hi = centre - half, centre + half
        cells, heads, chain = (np.empty((n, 3), dtype=np.int64), np.empty(1 << (2 * n - 1).bit_length(),
                                                                        dtype=np.int64), np.empty(n, dtype=np.int64))
        grid_swept_pairs(lo, hi, movable, cells, heads, chain, np.empty((n * n, 2), dtype=np.int64))
        fixed = np.flatnonzero(~movable).astype(np.int64)
        found = np.empty(n, dtype=np.int64)
        for _ in range(40):
            q_centre, q_half = rng.uniform(-1.2, 1.2, 3) * n ** (1 / 3) * 0.3, rng.uniform(0.005, 2.0, 3)
            slack = float(rng.choice([0.0, 1e-3]))
            qlo, qhi = q_centre - q_half, q_centre + q_half
            count = grid_overlaps(qlo, qhi, slack, lo, hi, movable, fixed, cells, heads, chain, found)
            brute = {i for i in range(n) if np.all(lo[i] <= qhi + slack) and np.all(qlo <= hi[i] + slack)}
            got = found[:count].tolist()
            assert len(got) == len(set(got)) and set(got) == brute


def test_bodies_out_of_their_free_box_are_paired_with_every_body_they_may_have_met():
    """left_pairs (kernels/contact/swept.py: the body–body pass's look again) against the brute force: bodies on
    free steps, some of them sent elsewhere (new ends and velocities, as an impact does), some skipped (an island's):
    the ones listed are exactly the movable, unskipped bodies whose box over the path as stepped is not inside
    their free step's box, and the pairs (as a set) exactly those of such a body with an unskipped movable body
    whose free box (or, for two such, new box) meets its new box and whose bounding spheres can meet on the chords
    as stepped."""
    from rigid_body_sim.core.kernels.contact.swept import (boxes_meet, grid_swept_pairs, left_pairs, spheres_may_meet,
                                                           swept_bounds)
    from rigid_body_sim.core.kernels.layout import P, ROW_WIDTH, V

    rng = np.random.default_rng(4)
    h = 0.01
    for n in (2, 40, 300):
        Y0, free = np.zeros((n, ROW_WIDTH)), np.zeros((n, ROW_WIDTH))
        Y0[:, P:P + 3], Y0[:, V:V + 3] = rng.uniform(-1.0, 1.0, (n, 3)) * n ** (1 / 3) * 0.2, rng.normal(0, 2, (n, 3))
        free[:, V:V + 3] = Y0[:, V:V + 3] + rng.normal(0, 0.1, (n, 3))
        free[:, P:P + 3] = Y0[:, P:P + 3] + 0.5 * h * (Y0[:, V:V + 3] + free[:, V:V + 3])
        stepped = free.copy()
        sent = rng.random(n) < 0.3
        stepped[sent, V:V + 3] = rng.normal(0, 4, (int(sent.sum()), 3))
        stepped[sent, P:P + 3] = Y0[sent, P:P + 3] + h * stepped[sent, V:V + 3]
        members, reach = np.arange(n, dtype=np.int64), rng.uniform(0.02, 0.15, n)
        movable, skip = rng.random(n) < 0.9, rng.random(n) < 0.1
        lo, hi, alo, ahi = np.empty((n, 3)), np.empty((n, 3)), np.empty((n, 3)), np.empty((n, 3))
        swept_bounds(Y0, free, members, reach, h, lo, hi)
        cells, heads, chain = (np.empty((n, 3), dtype=np.int64), np.empty(1 << (2 * n - 1).bit_length(),
                                                                        dtype=np.int64), np.empty(n, dtype=np.int64))
        grid_swept_pairs(lo, hi, movable, cells, heads, chain, np.empty((n * n, 2), dtype=np.int64))
        left, out = np.empty(n, dtype=np.int64), np.empty((n * n, 2), dtype=np.int64)
        n_left, count = left_pairs(Y0, stepped, members, reach, h, lo, hi, movable,
                                   np.flatnonzero(~movable).astype(np.int64), skip, cells, heads, chain, alo, ahi,
                                   left, np.empty(n, dtype=np.int64), out)
        new_lo, new_hi = np.empty((n, 3)), np.empty((n, 3))
        swept_bounds(Y0, stepped, members, reach, h, new_lo, new_hi)
        outside = movable & ~skip & (np.any(new_lo < lo, axis=1) | np.any(new_hi > hi, axis=1))
        assert sorted(left[:n_left].tolist()) == np.flatnonzero(outside).tolist()
        one = np.zeros((1, 2), dtype=np.int64)

        def may_meet(m, k):
            one[0] = m, k
            return spheres_may_meet(Y0, stepped, members, reach, h, NO_HALF_SPACES, one, 1) == 1

        brute = set()
        for m in np.flatnonzero(outside).tolist():
            for k in range(n):
                if k == m or not movable[k] or skip[k]:
                    continue
                meets = boxes_meet(new_lo[m], new_hi[m], lo[k], hi[k], 0.0) or (
                    outside[k] and boxes_meet(new_lo[m], new_hi[m], new_lo[k], new_hi[k], 0.0))
                if meets and may_meet(m, k):
                    brute.add((min(m, k), max(m, k)))
        assert {(min(a, b), max(a, b)) for a, b in out[:count].tolist()} == brute
        assert n < 40 or brute  # the scene has pairs to find


def test_swept_bounds_hold_the_path_of_a_constant_acceleration_and_of_a_body_held():
    """A body under constant acceleration a stays, all along the step, within its swept box (the chord grown by
    GROWTH |Δv| h ≥ |a| h²/8, the parabola's largest distance from its chord), and so does the same body held
    where it was by an island's step (p₀ + h v₀, its centre on a chord that far from the free one's)."""
    from rigid_body_sim.core.kernels.contact.swept import swept_bounds
    from rigid_body_sim.core.kernels.layout import P, ROW_WIDTH, V

    rng = np.random.default_rng(1)
    h = 0.01
    for _ in range(50):
        p0, v0, a = rng.normal(0, 1, 3), rng.normal(0, 5, 3), rng.normal(0, 50, 3)
        Y0, Y1 = np.zeros((1, ROW_WIDTH)), np.zeros((1, ROW_WIDTH))
        Y0[0, P:P + 3], Y0[0, V:V + 3] = p0, v0
        Y1[0, P:P + 3], Y1[0, V:V + 3] = p0 + v0 * h + 0.5 * a * h * h, v0 + a * h
        lo, hi = np.empty((1, 3)), np.empty((1, 3))
        swept_bounds(Y0, Y1, np.zeros(1, dtype=np.int64), np.array([0.0]), h, lo, hi)
        t = np.linspace(0.0, h, 101)[:, None]
        path = p0 + v0 * t + 0.5 * a * t * t
        assert np.all(path >= lo[0] - 1e-15) and np.all(path <= hi[0] + 1e-15)
        held = p0 + v0 * t
        assert np.all(held >= lo[0] - 1e-15) and np.all(held <= hi[0] + 1e-15)


def test_swept_spheres_keep_every_pair_that_meets():
    """spheres_may_meet (kernels/contact/swept.py) drops a pair only when its bounding spheres stay apart all along
    the step: over random bodies under constant accelerations (closed-form paths, sampled at 1001 instants), every
    pair whose spheres touch at some instant is kept, and pairs that stay apart are dropped (the cull is not empty)."""
    from rigid_body_sim.core.kernels.contact.swept import spheres_may_meet
    from rigid_body_sim.core.kernels.layout import P, ROW_WIDTH, V

    rng = np.random.default_rng(2)
    h, n = 0.01, 60
    p0, v0, a = rng.uniform(-0.5, 0.5, (n, 3)), rng.normal(0, 5, (n, 3)), rng.normal(0, 50, (n, 3))
    radius = rng.uniform(0.02, 0.15, n)
    Y0, Y1 = np.zeros((n, ROW_WIDTH)), np.zeros((n, ROW_WIDTH))
    Y0[:, P:P + 3], Y0[:, V:V + 3] = p0, v0
    Y1[:, P:P + 3], Y1[:, V:V + 3] = p0 + v0 * h + 0.5 * a * h * h, v0 + a * h
    pairs = np.array([(i, j) for i in range(n) for j in range(i + 1, n)], dtype=np.int64)
    kept = spheres_may_meet(Y0, Y1, np.arange(n, dtype=np.int64), radius, h, NO_HALF_SPACES, pairs, len(pairs))
    kept_set = {tuple(q) for q in pairs[:kept].tolist()}
    t = np.linspace(0.0, h, 1001)[:, None, None]
    path = p0 + v0 * t + 0.5 * a * t * t  # (instants, bodies, 3)
    meeting = dropped = 0
    for i in range(n):
        for j in range(i + 1, n):
            gap = np.min(np.linalg.norm(path[:, j] - path[:, i], axis=1)) - radius[i] - radius[j]
            if gap <= 0.0:
                meeting += 1
                assert (i, j) in kept_set, f"pair {i}, {j} meets (gap {gap:.3g} m) but was dropped"
            dropped += (i, j) not in kept_set
    assert meeting > 20 and dropped > 100


def test_swept_spheres_keep_every_pair_a_ground_may_bring_together():
    """spheres_may_meet with the ground z ≥ 0: a body whose bounding sphere ends its free step below the ground is
    stopped by the ground's pass somewhere on its chord, and may go back along it (a rebound). Over random bodies
    falling at 2 to 6 m/s, some landing, each landing one stopped at a random point of its chord and sent back
    along it by a random part of what is left (sampled at 1001 instants), every pair whose spheres touch at some
    instant is kept; without the ground (the free chords only), some of those are dropped."""
    from rigid_body_sim.core.kernels.contact.swept import spheres_may_meet
    from rigid_body_sim.core.kernels.layout import P, ROW_WIDTH, V

    rng = np.random.default_rng(7)
    h, n = 0.01, 80
    radius = rng.uniform(0.02, 0.06, n)
    p0 = np.column_stack([rng.uniform(-0.15, 0.15, (n, 2)), radius + rng.uniform(0.0, 0.08, n)])
    v = np.column_stack([rng.normal(0, 0.5, (n, 2)), -rng.uniform(2.0, 6.0, n)])
    p1 = p0 + v * h
    Y0, Y1 = np.zeros((n, ROW_WIDTH)), np.zeros((n, ROW_WIDTH))
    Y0[:, P:P + 3], Y0[:, V:V + 3], Y1[:, P:P + 3], Y1[:, V:V + 3] = p0, v, p1, v
    lands = p1[:, 2] < radius
    stop, back = rng.uniform(0.0, 1.0, n), rng.uniform(0.0, 1.0, n)
    s = np.linspace(0.0, 1.0, 1001)[:, None]
    along = np.where(lands, np.where(s <= stop, s, np.maximum(stop - back * (s - stop), 0.0)), s)  # (instants, n)
    path = p0 + along[:, :, None] * (p1 - p0)
    pairs = np.array([(i, j) for i in range(n) for j in range(i + 1, n)], dtype=np.int64)
    ground = np.zeros((1, 7))
    ground[0, 2] = 1.0

    def screened(grounds: np.ndarray) -> set:
        rows = pairs.copy()
        return {tuple(q) for q in rows[:spheres_may_meet(Y0, Y1, np.arange(n, dtype=np.int64), radius, h, grounds,
                                                         rows, len(rows))].tolist()}

    kept, free = screened(ground), screened(NO_HALF_SPACES)
    meeting = missed_free = 0
    for i, j in pairs.tolist():
        gap = np.min(np.linalg.norm(path[:, j] - path[:, i], axis=1)) - radius[i] - radius[j]
        if gap <= 0.0:
            meeting += 1
            assert (i, j) in kept, f"pair {i}, {j} meets (gap {gap:.3g} m) but was dropped"
            missed_free += (i, j) not in free
    print(f"{lands.sum()} landing; {meeting} pairs meet, {missed_free} of them dropped on the free chords; kept "
          f"{len(kept)}, free chords {len(free)} of {len(pairs)}")
    assert lands.sum() > 10 and meeting > 20 and missed_free > 0 and len(kept) < len(pairs)
