"""Bodies held by two ground half-spaces at once (core/contact/two_grounds.py), against closed forms.

The groove: two half-spaces n·x ≥ 0 with normals n_A = (0, −sin β, cos β), n_B = (0, sin β, cos β),
β = 45°: a right-angled V along x. Gravity g = 9.81 tilted by θ in the x–z plane, (g sin θ, 0,
−g cos θ), so the crease runs downhill along +x. A body touching both faces and moving along the
crease has the same acceleration along x as on an incline, with the normal forces of the two
faces summing to m g cos θ / cos β (each m g cos θ / (2 cos β)):

* frictionless, any shape: a = g sin θ;
* a ball (r, I = ⅖ m r²) rolling without slipping on the two contact points, at r cos β below its
  centre (the axis of rolling): a = g sin θ / (1 + ⅖ / cos² β);
* a capsule lying along the crease, sliding with friction μ on both faces: a = g (sin θ − μ cos θ / cos β)
  (it slides from rest when tan θ > μ / cos β).

The corner: a level floor n = (0, 0, 1) and a wall n = (−1, 0, 0), x ≤ 1, gravity tilted by θ
towards the wall. A ball (r = 0.1 m) launched on the floor at (0.5, 0.3, 0) m/s, frictionless,
e = 0: it reaches the wall when 0.5 t + ½ g sin θ t² = 1 − r, stops against it (e = 0), and then
slides along the crease at 0.3 m/s for ever, held by both.

A capsule slid into a static wall while just lifting off the floor, one end raised: held on the wall and the
floor, its raised end comes down onto the floor and stays on it (never below it, K + U never rising); it comes
to rest lying level in the crease, r from both.

A thin can rolling without slipping on its rim in the corner of the floor and a wall, held on both: no force does
work, so K + U is constant; with its holding force found at every rk4 stage, each step's error in it is rk4's. A
can lying with its end face on a wall (its rim point there swinging round the rim as it turns) keeps the force of
the step's start and is never left below the floor.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from contact_support import bin_walls
from helpers import ORDER, loglog_slope

from rigid_body_sim.core import Simulator
from rigid_body_sim.core.contact.query import lowest_gaps
from rigid_body_sim.core.kernels.contact.layout import PERSISTENT
from rigid_body_sim.core.quaternion import quat_rotate
from rigid_body_sim.core.scene import load_scene, load_scene_text

G = 9.81
BETA = math.radians(45.0)
C = math.cos(BETA)
S45 = math.sqrt(0.5)


def groove(theta: float, mu: float, body: str) -> str:
    return f"""
gravity: [{G * math.sin(theta)}, 0.0, {-G * math.cos(theta)}]
ground:
  - {{normal: [0, {-math.sin(BETA)}, {C}], offset: 0.0, material: {{restitution: 0.0, friction: {mu}}}}}
  - {{normal: [0, {math.sin(BETA)}, {C}], offset: 0.0, material: {{restitution: 0.0, friction: {mu}}}}}
bodies:
{body}"""


BALL = """  ball:
    mass: 1.0
    inertia: {sphere: 0.1}
    pose: {position: [0.0, 0.0, %r]}
""" % (0.1 / C + 1e-13)
ROD = """  rod:
    mass: 1.0
    inertia: {cylinder: [0.05, 0.4]}
    collision: {capsule: [0.05, 0.3]}
    pose: {position: [0.0, 0.0, %r], orientation: [0, %r, 0, %r]}
""" % (0.05 / C + 1e-13, S45, S45)


def slide(scene_text: str, body: str, integrator: str, dt: float, seconds: float = 1.0) -> Simulator:
    sim = Simulator(load_scene_text(scene_text, "groove"), integrator, dt)
    assert sim.contact.is_resting(body) and sim.contact.other_ground[0] == 1  # held by both faces from the start
    sim.step(int(round(seconds / dt)))
    return sim


def gaps(sim: Simulator, body: str) -> np.ndarray:
    """The body's lowest gap to each half-space (m)."""
    from rigid_body_sim.core.kernels.contact.layout import MAX_POINTS
    from rigid_body_sim.core.kernels.contact.shapes import body_points

    y = sim._Ys[sim._control[0]][0]
    points, g = np.empty((MAX_POINTS, 3)), np.empty(MAX_POINTS)
    out = []
    for ground in sim.contact.grounds:
        n = body_points(y, sim._prm[0], sim.contact.shapes[0], ground, points, g)
        out.append(g[:n].min())
    return np.array(out)


def test_ball_resting_in_a_level_groove_stays_put_held_by_both_faces() -> None:
    """Level crease (θ = 0), μ = 0.5, dt = 10 ms: no motion at all over 10 s (≤ 1e-12), on both faces (gap ≤ 1e-12),
    held by m g straight up (the two faces' m g / (2 cos β) each, along their normals)."""
    sim = slide(groove(0.0, 0.5, BALL), "ball", "rk4", 1e-2, seconds=10.0)
    state = sim.body_state("ball")
    assert np.linalg.norm(state.linear_velocity_world) <= 1e-12 and np.linalg.norm(state.angular_velocity_world) <= 1e-12
    np.testing.assert_allclose(state.position_world, [0.0, 0.0, 0.1 / C], rtol=0, atol=1e-12)
    np.testing.assert_allclose(gaps(sim, "ball"), 0.0, atol=1e-12)
    np.testing.assert_allclose(sim.contact.holding_forces[0], [0.0, 0.0, G], rtol=0, atol=1e-12)


@pytest.mark.parametrize("integrator", ["rk4", "reference", "splitting", "symmetric_splitting"])
def test_frictionless_ball_slides_down_the_crease_at_g_sin_theta(integrator) -> None:
    theta = math.radians(20.0)
    sim = slide(groove(theta, 0.0, BALL), "ball", integrator, 1e-3)
    x = sim.body_state("ball").position_world
    assert abs(x[0] / (0.5 * G * math.sin(theta)) - 1.0) <= 1e-9
    np.testing.assert_allclose(x[1:], [0.0, 0.1 / C], rtol=0, atol=1e-12)
    np.testing.assert_allclose(gaps(sim, "ball"), 0.0, atol=1e-12)


@pytest.mark.parametrize("integrator", ["rk4", "reference"])
def test_ball_rolls_down_the_crease_on_its_two_contact_points(integrator) -> None:
    """μ = 1 (the cone holds both points): a = g sin θ / (1 + ⅖ / cos² β), and ω = v / (r cos β) about y."""
    theta = math.radians(20.0)
    sim = slide(groove(theta, 1.0, BALL), "ball", integrator, 1e-3)
    state = sim.body_state("ball")
    a = G * math.sin(theta) / (1.0 + 0.4 / C**2)
    assert abs(state.position_world[0] / (0.5 * a) - 1.0) <= 1e-9
    assert abs(state.linear_velocity_world[0] / a - 1.0) <= 1e-9
    np.testing.assert_allclose(state.angular_velocity_world, [0.0, a / (0.1 * C), 0.0], rtol=1e-9, atol=1e-12)
    assert not sim.contact.sliding[0]


@pytest.mark.parametrize("integrator", ["rk4", "reference", "splitting"])
def test_capsule_slides_down_the_crease_with_friction_from_rest(integrator) -> None:
    """θ = 30°, μ = 0.2 (tan θ = 0.577 > μ / cos β = 0.283: the cone cannot hold it, it starts to slide):
    a = g (sin θ − μ cos θ / cos β), without turning."""
    theta, mu = math.radians(30.0), 0.2
    sim = slide(groove(theta, mu, ROD), "rod", integrator, 1e-3)
    state = sim.body_state("rod")
    a = G * (math.sin(theta) - mu * math.cos(theta) / C)
    assert abs(state.position_world[0] / (0.5 * a) - 1.0) <= 1e-9
    assert np.linalg.norm(state.angular_velocity_world) <= 1e-12
    assert sim.contact.sliding[0]
    np.testing.assert_allclose(gaps(sim, "rod"), 0.0, atol=1e-12)


def test_capsule_sliding_down_the_crease_converges_at_first_order_with_semi_implicit_euler() -> None:
    theta, mu = math.radians(30.0), 0.2
    a = G * (math.sin(theta) - mu * math.cos(theta) / C)
    dts = np.array([4e-3, 2e-3, 1e-3])
    errors = [abs(slide(groove(theta, mu, ROD), "rod", "semi_implicit_euler", dt, 0.4).body_state("rod")
                  .position_world[0] / (0.5 * a * 0.4**2) - 1.0) for dt in dts]
    assert abs(loglog_slope(dts, np.array(errors)) - ORDER["semi_implicit_euler"]) < 0.1, errors


def test_ball_sliding_into_a_wall_stops_against_it_and_slides_along_the_crease() -> None:
    theta, r, v0 = math.radians(10.0), 0.1, 0.5
    scene = f"""
gravity: [{G * math.sin(theta)}, 0.0, {-G * math.cos(theta)}]
ground:
  - {{normal: [0, 0, 1], offset: 0.0, material: {{restitution: 0.0, friction: 0.0}}}}
  - {{normal: [-1, 0, 0], offset: -1.0, material: {{restitution: 0.0, friction: 0.0}}}}
bodies:
  ball:
    mass: 1.0
    inertia: {{sphere: {r}}}
    pose: {{position: [0.0, 0.0, {r}]}}
    twist: {{linear: [{v0}, 0.3, 0]}}
"""
    sim = Simulator(load_scene_text(scene, "corner"), "rk4", 1e-3)
    sim.step(2000)
    a = G * math.sin(theta)
    t_hit = (-v0 + math.sqrt(v0 * v0 + 2.0 * a * (1.0 - r))) / a
    impacts = sim.contact.events_of("ball", "impact")
    assert len(impacts) == 1 and impacts[0].ground == 1 and abs(impacts[0].time - t_hit) <= 1e-9
    state = sim.body_state("ball")
    np.testing.assert_allclose(state.position_world, [1.0 - r, 0.3 * 2.0, r], rtol=0, atol=1e-9)
    np.testing.assert_allclose(state.linear_velocity_world, [0.0, 0.3, 0.0], rtol=0, atol=1e-12)
    assert sim.contact.other_ground[0] == 1 and sim.contact.counts["second_half_space"] == 1
    np.testing.assert_allclose(gaps(sim, "ball"), 0.0, atol=1e-12)


@pytest.mark.parametrize("third", ["half-space", "static box"])
def test_ball_sliding_along_the_crease_into_a_third_wall_stops_there_without_entering_it(third) -> None:
    """The corner above with a third wall across the crease, y ≤ 0.5 (a half-space, or the face of a static box):
    the ball, held on the floor and the first wall, slides along the crease at 0.3 m/s into it and stops there
    (e = 0, frictionless). Taken in at the end of the step it reaches it in (not located: the impact is listed at
    that step's end, within a step of t = (0.5 − r)/0.3, with the jump of a stop from 0.3 m/s: Δv = (0, −0.3, 0),
    impulse 0.3 N·s, kinetic energy 0.045 J to 0), it never ends a step inside any of the three (1e-12 m) and rests
    in the corner, at (1 − r, 0.5 − r, r) with no speed (1e-9)."""
    theta, r, v0, dt = math.radians(10.0), 0.1, 0.5, 1e-3
    wall = ("  - {normal: [0, -1, 0], offset: -0.5, material: {restitution: 0.0, friction: 0.0}}"
            if third == "half-space" else "")
    box = ("""  wall:
    motion: static
    mass: 1.0
    inertia: {box: [2.0, 0.2, 1.0]}
    collision: {box: [2.0, 0.2, 1.0]}
    material: {restitution: 0.0, friction: 0.0}
    pose: {position: [0.0, 0.6, 0.5]}
""" if third == "static box" else "")
    scene = f"""
gravity: [{G * math.sin(theta)}, 0.0, {-G * math.cos(theta)}]
ground:
  - {{normal: [0, 0, 1], offset: 0.0, material: {{restitution: 0.0, friction: 0.0}}}}
  - {{normal: [-1, 0, 0], offset: -1.0, material: {{restitution: 0.0, friction: 0.0}}}}
{wall}
bodies:
  ball:
    mass: 1.0
    inertia: {{sphere: {r}}}
    material: {{restitution: 0.0, friction: 0.0}}
    pose: {{position: [0.0, 0.0, {r}]}}
    twist: {{linear: [{v0}, 0.3, 0]}}
{box}"""
    sim = Simulator(load_scene_text(scene, "corner"), "rk4", dt, threads=1)
    for _ in range(2000):
        sim.step()
        y = sim.body_state("ball").position_world
        assert min(y[2] - r, 1.0 - r - y[0], 0.5 - r - y[1]) >= -1e-12
    impacts = sim.contact.events_of("ball", "impact")
    assert len(impacts) == 2 and impacts[0].ground == 1
    third_wall = impacts[1]
    assert 0.0 <= third_wall.time - (0.5 - r) / 0.3 <= dt + 1e-12 and sim.contact.counts["third_half_space"] == 1
    # the jump of an inelastic stop from 0.3 m/s along the crease: what the IMU and `contacts` read
    np.testing.assert_allclose(third_wall.delta_v_world, [0.0, -0.3, 0.0], rtol=0, atol=1e-12)
    np.testing.assert_allclose(third_wall.delta_w_principal, 0.0, rtol=0, atol=1e-12)
    assert third_wall.impulse == pytest.approx(0.3, abs=1e-12)
    assert third_wall.energy_before == pytest.approx(0.5 * 0.3 ** 2, abs=1e-12) and abs(third_wall.energy_after) <= 1e-24
    state = sim.body_state("ball")
    np.testing.assert_allclose(state.position_world, [1.0 - r, 0.5 - r, r], rtol=0, atol=1e-9)
    assert np.abs(state.linear_velocity_world).max() <= 1e-9 and np.abs(state.angular_velocity_world).max() <= 1e-9


def test_box_sliding_into_a_wall_stops_against_it_and_slides_along_the_crease() -> None:
    """The corner with a cube (0.2 m) instead of the ball: a face on each half-space is 8 contact points,
    more than the rows hold together, so it is held on the floor and projected onto both after each step
    (first order in the wall's force; frictionless here, so the closed form still holds): the impact when
    0.5 t + ½ g sin θ t² = 0.9 m, then along the crease at 0.3 m/s, at (0.9, 0.3 t, 0.1) m."""
    theta, v0 = math.radians(10.0), 0.5
    scene = f"""
gravity: [{G * math.sin(theta)}, 0.0, {-G * math.cos(theta)}]
ground:
  - {{normal: [0, 0, 1], offset: 0.0, material: {{restitution: 0.0, friction: 0.0}}}}
  - {{normal: [-1, 0, 0], offset: -1.0, material: {{restitution: 0.0, friction: 0.0}}}}
bodies:
  crate:
    mass: 1.0
    inertia: {{box: [0.2, 0.2, 0.2]}}
    pose: {{position: [0.0, 0.0, 0.1]}}
    twist: {{linear: [{v0}, 0.3, 0]}}
"""
    sim = Simulator(load_scene_text(scene, "corner"), "rk4", 1e-3)
    sim.step(2000)
    a = G * math.sin(theta)
    t_hit = (-v0 + math.sqrt(v0 * v0 + 2.0 * a * 0.9)) / a
    impacts = sim.contact.events_of("crate", "impact")
    assert len(impacts) == 1 and impacts[0].ground == 1 and abs(impacts[0].time - t_hit) <= 1e-9
    state = sim.body_state("crate")
    np.testing.assert_allclose(state.position_world, [0.9, 0.6, 0.1], rtol=0, atol=1e-9)
    np.testing.assert_allclose(state.linear_velocity_world, [0.0, 0.3, 0.0], rtol=0, atol=1e-12)
    assert np.linalg.norm(state.angular_velocity_world) <= 1e-12
    assert sim.contact.other_projected[0] and sim.contact.counts["two_ground_overflow"] >= 1
    np.testing.assert_allclose(gaps(sim, "crate"), 0.0, atol=1e-12)


def test_capsule_thrown_into_the_corner_of_the_floor_and_a_static_wall_lands_its_raised_end_there() -> None:
    """A capsule (r = 3 cm, half-length 3.6 cm) lying along a static wall, tilted 0.02 rad (one end raised), slid
    into the wall at 0.2 m/s while just lifting off the floor (0.01 m/s: in flight, so the wall becomes its ground
    and the floor its second one), μ = 0.5, e = 0, dt = 10 ms. Its raised end comes down onto the floor (the wall let
    go where it no longer presses on it): both ends held there, it never sinks into it (every step, the lowest gap
    ≥ −1e-9 m),
    K + U never rises above its start, and after 0.6 s it lies at rest in the crease: axis level, centre at
    z = r and r from the wall (1e-9)."""
    r, half, tilt = 0.03, 0.036, 0.02
    along = np.array([math.cos(tilt), 0.0, math.sin(tilt)])
    centre = np.array([0.0, -0.2 + r + 1e-4, r]) + half * along
    turn = math.acos(along[2])  # the capsule's own z onto ``along``, about y
    material = "{restitution: 0.0, friction: 0.5}"
    scene = f"""
gravity: [0.0, 0.0, {-G}]
ground:
  - {{normal: [0, 0, 1], offset: 0.0, material: {material}}}
bodies:
  can:
    mass: 1.0
    inertia: {{cylinder: [{r}, {2 * half + 1.4 * r}]}}
    collision: {{capsule: [{r}, {half}]}}
    material: {material}
    pose: {{position: [{centre[0]}, {centre[1]}, {centre[2]}], orientation: [0.0, {math.sin(turn / 2)}, 0.0, {math.cos(turn / 2)}]}}
    twist: {{linear: [0.0, -0.2, 0.01]}}
  wall:
    motion: static
    mass: 1.0
    inertia: {{box: [1.0, 0.1, 1.0]}}
    collision: {{box: [1.0, 0.1, 1.0]}}
    material: {material}
    pose: {{position: [0.0, -0.25, 0.5]}}
"""
    sim = Simulator(load_scene_text(scene, "crease"), "rk4", 1e-2, threads=1)

    def energy() -> float:
        return float(sim.kinetic_energy()[0] + sim.potential_energy()[0])

    start = energy()
    landed = False  # both ends held on the floor (its ground or, held on the wall, its second one)
    for _ in range(60):
        sim.step()
        assert float(lowest_gaps(sim)[0]) >= -1e-9
        assert energy() <= start + 1e-12 * abs(start)
        contact = sim.contact
        landed |= ((contact.other_ground[0] == 0 and contact.other_tracked[0] == 0b11)
                   or (contact.ground_of[0] == 0 and contact.tracked[0] == 0b11))
    assert landed
    state = sim.body_state("can")
    np.testing.assert_allclose(state.position_world[1:], [-0.2 + r, r], rtol=0, atol=1e-9)
    axis = quat_rotate(np.roll(state.orientation_xyzw, 1), np.array([0.0, 0.0, 1.0]))  # its own z, world
    np.testing.assert_allclose(axis, [1.0, 0.0, 0.0], rtol=0, atol=1e-9)
    assert np.abs(state.linear_velocity_world).max() <= 1e-9 and np.abs(state.angular_velocity_world).max() <= 1e-9


def can_in_a_corner(dt: float) -> Simulator:
    """A thin can (r = 64 mm, 23 mm long, 4.96 kg) rolling on its rim on the floor (μ 0.6 with the can's 0.44),
    the same point of its rim against a static wall's face (y ≥ −0.475 m), at 0.05 m/s and 3.4 rad/s: a state a
    mixed pile left one in. rk4 at ``dt``; held on the wall's face and the floor at once from the start."""
    can = {"mass": 4.95616539659454, "inertia": {"cylinder": [0.0641536571448833, 0.022586604906178608]},
           "collision": {"cylinder": [0.0641536571448833, 0.022586604906178608]},
           "material": {"restitution": 0.0, "friction": 0.4356541530837637},
           "pose": {"position": [0.40515055045201825, -0.43041990043071304, 0.06054491427091334],
                    "orientation": [0.5725309858511818, 0.6591279928824779, -0.42089749573800705,
                                    0.24617850702379446]},
           "twist": {"linear": [-0.043934293617658306, -0.02782124468696822, -0.01407713787206939],
                     "angular": [0.24907312720046493, -1.8441600604823507, 2.8673425485166737]}}
    box = {"box": [1.15, 0.1, 1.0]}
    wall = {"motion": "static", "mass": 1.0, "inertia": box, "collision": box,
            "material": {"restitution": 0.0, "friction": 0.5}, "pose": {"position": [0.0, -0.525, 0.5]}}
    scene = {"gravity": [0.0, 0.0, -G], "bodies": {"can": can, "wall": wall},
             "ground": [{"normal": [0, 0, 1], "material": {"restitution": 0.0, "friction": 0.6}}]}
    sim = Simulator(load_scene(scene), "rk4", dt, threads=1)
    assert sim.contact.is_resting("can") and sim.contact.other_ground[0] >= 0
    return sim


def test_a_can_rolling_on_its_rim_held_on_a_wall_and_the_floor_gains_energy_only_at_rk4s_order() -> None:
    """The can in the corner (:func:`can_in_a_corner`) rolls without slipping on both planes: no force does work,
    K + U is constant. Its holding force changes as the rim point moves over the can; found at every rk4 stage
    (as on one plane), each step's error in K + U is rk4's, O(dt⁵). Over 0.6 s at dt = 10, 5 and 2.5 ms the can
    stays held on both planes; the largest rise of K + U in a step is at most 1e-7 of it at 10 ms and falls at
    least as dt⁴. (With the force of the step's start kept over the step: 2.95 mJ a step, 1e-3 of it.)"""
    dts = np.array([1e-2, 5e-3, 2.5e-3])
    rises, start = [], 0.0
    for dt in dts:
        sim = can_in_a_corner(dt)
        start = last = float(sim.kinetic_energy()[0] + sim.potential_energy()[0])
        worst = 0.0
        for _ in range(int(round(0.6 / dt))):
            sim.step()
            assert sim.contact.other_ground[0] >= 0 and sim.contact.modes[0] == PERSISTENT
            energy = float(sim.kinetic_energy()[0] + sim.potential_energy()[0])
            worst, last = max(worst, energy - last), energy
        rises.append(worst)
    assert rises[0] <= 1e-7 * start, rises
    assert loglog_slope(dts, np.array(rises)) >= ORDER["rk4"], rises


def _can_lying_on_a_wall(lift: float = 0.0) -> Simulator:
    """The frictionless can of the two tests below, lying on its side on the floor with its end face on a wall,
    its centre raised by ``lift`` (m)."""
    cylinder = {"cylinder": [0.05070852434398963, 0.033023474331812644]}
    can = {"mass": 4.251809383644751, "inertia": cylinder, "collision": cylinder,
           "material": {"restitution": 0.0, "friction": 0.0},
           "pose": {"position": [0.27414239177935273, -0.5834877717463015, 0.050708651318412824 + lift],
                    "orientation": [0.37029007236502326, 0.6024027783055157, 0.6023968862298114,
                                    -0.37028927402549655]},
           "twist": {"linear": [0.0, 4.207255940408499e-05, 1.16832190431957e-05],
                     "angular": [-0.0007075872664979253, -8.528997210094716e-10, 0.00030427001790678623]}}
    wall = {"motion": "static", "mass": 1.0, "inertia": {"box": [1.4, 0.1, 1.0]}, "collision": {"box": [1.4, 0.1, 1.0]},
            "material": {"restitution": 0.0, "friction": 0.5}, "pose": {"position": [0.0, -0.65, 0.5]}}
    scene = {"gravity": [0.0, 0.0, -G], "bodies": {"can": can, "wall": wall},
             "ground": [{"normal": [0, 0, 1], "material": {"restitution": 0.0, "friction": 0.6}}]}
    return Simulator(load_scene(scene), "rk4", 1e-2, threads=1)


@pytest.mark.parametrize("lift", [0.0, 1e-6])
def test_a_can_lying_with_its_end_face_on_a_wall_never_gains_energy(lift) -> None:
    """The can of :func:`_can_lying_on_a_wall`, under gravity alone, from resting on the floor (or dropped 1 µm):
    held on one rim point on the floor and one on the wall, its other rim 2.6e-7 m up, the wall's force holds it
    up until that rim lands, a fraction of a millisecond into the step. Held over the whole 10 ms step, that force
    pushed it off the wall at 2.2 cm/s, spinning at 0.43 rad/s: a step's K + U rose 1.3 mJ (6e-4 of it). Such a
    step is taken again in pieces, as on one plane: over 0.3 s its K + U never rises above its start, no step
    raises it by more than 5e-6 of it (what the finest pieces still add, counted in ``energy_gains``), and it
    leaves the wall at under 1 mm/s."""
    sim = _can_lying_on_a_wall(lift)
    start = last = float(sim.kinetic_energy()[0] + sim.potential_energy()[0])
    worst = 0.0
    for _ in range(30):
        sim.step()
        energy = float(sim.kinetic_energy()[0] + sim.potential_energy()[0])
        assert energy <= start + 1e-12 * abs(start), (sim.time, energy - start)
        worst, last = max(worst, energy - last), energy
    assert worst <= 5e-6 * abs(start), worst
    assert sim.contact.counts["refined_steps"] >= 1
    assert sim.contact.energy_gains >= (1 if worst > 1e-12 * abs(start) else 0)
    assert float(np.linalg.norm(sim.linear_velocities_world()[0])) < 1e-3


def test_a_can_lying_with_its_end_face_on_a_wall_is_not_left_below_the_floor() -> None:
    """A frictionless can (r = 51 mm, 33 mm long, 4.25 kg) lying on its side on the floor, its end face on a wall
    (y ≥ −0.6 m), its axis 1e-5 rad off the wall's normal, nearly at rest (4e-5 m/s): a state a mixed pile left one
    in. Its first step leaves it held on a rim point on the floor and one on the wall, its other rim 3.1e-7 m
    below the floor. Its rim point on the wall, near upright to it, swings round the rim as it turns: with the
    force found at every stage rk4 threw it (1.5e7 J in a step), and it was left at rest there, 3.1e-7 m below the
    floor, step after step. The force of the step's start is held on such a rim instead: over 10 steps of
    10 ms, from the second on, it is never below the floor by more than 1e-9 m."""
    sim = _can_lying_on_a_wall()
    sim.step()
    assert sim.contact.other_ground[0] >= 0  # held on the floor and the wall
    for _ in range(10):
        sim.step()
        assert float(lowest_gaps(sim)[0]) >= -1e-9


def test_a_capsule_held_on_the_floor_and_a_wall_is_taken_out_of_the_next_wall_its_end_swings_into() -> None:
    """A frictionless capsule (r = 31 mm, 74 mm between its ends' centres, 4.5 kg) thrown into the corner of a bin
    (walls' inner faces at x = −0.725 m and y = 0.725 m), a state a mixed pile left one in: it lands on one end,
    sliding away from the corner, and is held on the floor and one wall while its raised end swings down. Where
    that end went into the other wall within a step but its point there was moving out of it at the step's end, it
    was left in it (27.6 µm deep at dt = 10 ms with semi-implicit Euler, against a 10 µm tolerance): a third plane
    was taken in only when the feature in it still moved further in. Over 10 steps the capsule is never inside
    either wall or the floor by more than the tolerance (each depth from the capsule's end points)."""
    capsule = {"mass": 4.504818866173378, "inertia": {"cylinder": [0.030930759431182318, 0.13583207726699917]},
               "collision": {"capsule": [0.030930759431182318, 0.07397055840463454]},
               "material": {"restitution": 0.0, "friction": 0.0},
               "pose": {"position": [-0.6801388034062744, 0.6885535054544565, 0.09000837114327608],
                        "orientation": [-0.1649422318631542, 0.11076384940090314, -0.638709487424,
                                        0.7433543034707386]},
               "twist": {"linear": [-0.18030163381938535, 1.28528371789652, -3.531011796733501],
                         "angular": [-1.4859995790574185, -5.788152822287173, -2.728235866528224]}}
    scene = {"gravity": [0.0, 0.0, -G], "bodies": {"capsule": capsule, **bin_walls(1.45)},
             "ground": [{"normal": [0, 0, 1], "material": {"restitution": 0.0, "friction": 0.6}}]}
    tolerance = 1e-5
    sim = Simulator(load_scene(scene), "semi_implicit_euler", 1e-2, threads=1)
    sim.contact.penetration_tolerance = tolerance
    radius, half = 0.030930759431182318, 0.07397055840463454 / 2
    held_on_both = 0
    for _ in range(10):
        sim.step()
        axis = quat_rotate(np.roll(sim.orientations_xyzw()[0], 1), np.array([0.0, 0.0, 1.0]))
        ends = sim.positions_world()[0] + np.outer([-half, half], axis)
        assert -0.725 - (ends[:, 0].min() - radius) <= tolerance + 1e-9  # into the x wall
        assert ends[:, 1].max() + radius - 0.725 <= tolerance + 1e-9  # into the y wall
        assert -(ends[:, 2].min() - radius) <= tolerance + 1e-9  # into the floor
        held_on_both += sim.contact.other_ground[0] >= 0
    assert held_on_both >= 1
