"""Static bodies with a shape are contact geometry: impacts located and resolved against closed forms.

A static body (``motion: static``) with a collision shape, in a scene with a ``ground`` key
(here ``ground: []``: no half-space at all), is an obstacle of infinite mass. The cases:

* a ball (r = 0.1 m) dropped with its lowest point h0 = 0.5 m above a static box's top face,
  e = 0.5: the same closed form as on the ground (impact k at t_k = t1 + Σ_{j<k} 2 e^j v1/g,
  rebound e^k v1, apexes e^{2k} h0), rk4 at dt = 1 ms: 1e-9 relative (a parabola is exact for
  rk4, so only round-off and the event location remain); then at rest on the face at
  T = t1 (1 + e)/(1 − e) (the Zeno guard), gap 0;
* a frictionless ball flying (no gravity) at a static box's edge, at its corner, and at a static
  ball: the impact at the root of |c0 + v t − x_edge(t)| = r (a quadratic), and the velocity after
  it v − (1 + e)(v·n) n with n the unit normal from the contact point to the ball's centre; spin
  unchanged;
* a box dropped flat onto a static box's top face comes to rest and stays: its lowest corner's
  gap to the face (computed here from the pose) ≤ 1e-12 m and its speed ≤ 1e-12 m/s for 10 s
  (rk4, dt = 10 ms: resting is exact at any step);
* a box sliding on a frictionless floor into a static wall: the impact at the closed-form time,
  the rebound e v; a body starting inside a static shape is refused; the example scene;
* per-body materials: two crates with their own μ sliding to a stop on a static box's face
  (t = v/(μ g), d = v²/(2 μ g), 1e-9), two balls with their own e and μ dropped onto a static ball
  and a static capsule (their tangent rows: the closed-form impact, one sliding, one sticking,
  1e-9); 20,000 balls on a static floor: the static geometry's arrays are linear in the bodies
  and each body's materials on its face and tangent rows are its pair material;
* bodies spinning against a bin's walls step on (never gaining K + U), and a spinning can thrown at a static wall
  stays out of it (1e-5 m) when its steps are taken again in pieces.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from rigid_body_sim.core import SceneError, Simulator, load_scene
from rigid_body_sim.core.contact.query import lowest_gaps, overlapping_bodies
from rigid_body_sim.core.kernels.contact.layout import PERSISTENT
from rigid_body_sim.core.quaternion import quat_conjugate, quat_multiply, quat_rotate

from contact_support import bin_walls

CONFIG = Path(__file__).resolve().parents[1] / "config"
G, E, R = 9.81, 0.5, 0.1
TOP = 0.25  # m: the static box's top face (box 1 × 1 × 0.5 centred at the origin)


def _scene(bodies, gravity=G, box_material=None):
    table = {"mass": 10.0, "inertia": {"box": [1.0, 1.0, 0.5]}, "motion": "static",
             "pose": {"position": [0.0, 0.0, 0.0]}}
    if box_material is not None:
        table["material"] = box_material
    return load_scene({"gravity": [0.0, 0.0, -gravity], "ground": [], "bodies": {"table": table, **bodies}})


def _ball(position, velocity=(0.0, 0.0, 0.0), friction=0.3):
    return {"mass": 1.0, "inertia": {"sphere": R}, "material": {"restitution": E, "friction": friction},
            "pose": {"position": list(position)}, "twist": {"linear": list(velocity)}}


# ----------------------------------------------------------------------------- a ball on a static box's face

H0 = 0.5
T1 = math.sqrt(2.0 * H0 / G)
V1 = G * T1
REST = T1 * (1.0 + E) / (1.0 - E)


def _impact_time(k: int) -> float:
    return T1 + sum(2.0 * E**j * V1 / G for j in range(1, k))


def test_a_ball_bounces_on_a_static_box_like_on_the_ground():
    sim = Simulator(_scene({"ball": _ball([0.1, -0.2, TOP + R + H0])}, box_material={"restitution": E, "friction": 0.5}),
                    "rk4", 1e-3)
    times, heights, speeds = [], [], []
    while sim.time < REST + 0.1:
        sim.step()
        times.append(sim.time)
        heights.append(sim.state.p_WC_W[1, 2] - R - TOP)
        speeds.append(sim.state.v_WC_W[1, 2])
    times, heights, speeds = np.array(times), np.array(heights), np.array(speeds)
    impacts = sim.contact.events_of("ball", "impact")
    assert len(impacts) >= 3
    for k, event in enumerate(impacts[:3], start=1):
        assert event.time == pytest.approx(_impact_time(k), rel=1e-9)
        assert event.normal_speed_before == pytest.approx(-E ** (k - 1) * V1, rel=1e-9)
        assert event.normal_speed_after == pytest.approx(E**k * V1, rel=1e-9)
        assert sim.contact.static_body_of(event.ground) == "table"
    for k in (1, 2, 3):  # every sample of flights 1..3 has the closed-form apex e^{2k} h0
        inside = (times > _impact_time(k)) & (times < _impact_time(k + 1))
        assert inside.sum() >= 1
        apex = heights[inside] + speeds[inside] ** 2 / (2.0 * G)
        np.testing.assert_allclose(apex, H0 * E ** (2 * k), rtol=1e-9)
    rest = sim.contact.events_of("ball", "rest")
    assert len(rest) == 1 and rest[0].time == pytest.approx(REST, abs=1e-6)
    assert sim.contact.is_resting("ball")
    after = times > REST + 1e-3
    assert np.abs(heights[after]).max() <= 1e-12 and np.abs(speeds[after]).max() <= 1e-12


# ----------------------------------------------------------------------------- oblique impacts, no gravity

def _first_root(c0, v, centre_of, radius):
    """The first t > 0 with |c0 + v t − centre_of(t)| = radius, for a line of closest points (a quadratic)."""
    # centre_of(t) = a + b t: solve |(c0 − a) + (v − b) t|² = radius²
    a = centre_of(0.0)
    b = centre_of(1.0) - a
    d0, dv = c0 - a, v - b
    qa, qb, qc = dv @ dv, 2.0 * d0 @ dv, d0 @ d0 - radius * radius
    return (-qb - math.sqrt(qb * qb - 4.0 * qa * qc)) / (2.0 * qa)


def _fly_into(bodies, c0, v, nearest_point, radius, table="table"):
    """Fly the ball (index 1) until after its first impact; check the impact time and velocity against the
    closed form: n from the contact point to the centre, v⁺ = v − (1 + e)(v·n) n, frictionless, no spin."""
    sim = Simulator(load_scene({"gravity": [0.0, 0.0, 0.0], "ground": [], "bodies": bodies}), "rk4", 1e-3)
    t_hit = _first_root(c0, v, lambda t: nearest_point(c0 + v * t), radius)
    while not sim.contact.events_of("ball", "impact"):
        sim.step()
    event = sim.contact.events_of("ball", "impact")[0]
    assert event.time == pytest.approx(t_hit, rel=1e-9)
    c_hit = c0 + v * t_hit
    n = (c_hit - nearest_point(c_hit)) / radius
    expected = v - (1.0 + E) * (v @ n) * n
    np.testing.assert_allclose(np.array(event.delta_v_world) + v, expected, rtol=0, atol=1e-9 * np.linalg.norm(v))
    np.testing.assert_allclose(sim.state.v_WC_W[1], expected, rtol=0, atol=1e-9 * np.linalg.norm(v))
    np.testing.assert_allclose(sim.state.w_WP_P[1], 0.0, atol=1e-12)
    assert sim.contact.static_body_of(event.ground) == table
    assert event.energy_after <= event.energy_before


def test_a_frictionless_ball_hits_a_static_box_edge_obliquely():
    half = np.array([0.5, 0.5, 0.25])
    c0, v = np.array([0.9, 0.1, 0.45]), np.array([-1.0, 0.2, -0.37])  # towards the edge x = 0.5, z = 0.25

    def edge(c):  # the nearest point of the box's edge along y at (x, z) = (0.5, 0.25)
        return np.array([half[0], c[1], half[2]])

    ball = _ball(c0, v, friction=0.0)
    table = {"mass": 10.0, "inertia": {"box": [1.0, 1.0, 0.5]}, "motion": "static", "material": {"restitution": E, "friction": 0.0}}
    _fly_into({"table": table, "ball": ball}, c0, v, edge, R)


def test_a_frictionless_ball_hits_a_static_box_corner():
    corner = np.array([0.5, 0.5, 0.25])
    c0, v = np.array([0.8, 0.75, 0.55]), np.array([-0.9, -0.7, -0.8])
    ball = _ball(c0, v, friction=0.0)
    table = {"mass": 10.0, "inertia": {"box": [1.0, 1.0, 0.5]}, "motion": "static", "material": {"restitution": E, "friction": 0.0}}
    _fly_into({"table": table, "ball": ball}, c0, v, lambda c: corner, R)


def test_a_frictionless_ball_hits_a_static_ball():
    centre, radius = np.array([0.0, 0.0, 0.0]), 0.3
    c0, v = np.array([1.0, 0.15, -0.1]), np.array([-2.0, 0.1, 0.05])
    ball = _ball(c0, v, friction=0.0)
    post = {"mass": 1.0, "inertia": {"sphere": radius}, "motion": "static", "material": {"restitution": E, "friction": 0.0}}
    _fly_into({"post": post, "ball": ball}, c0, v, lambda c: centre, R + radius, table="post")


# ----------------------------------------------------------------------------- a box resting on a static box

def test_a_box_dropped_flat_on_a_static_box_comes_to_rest_and_stays():
    side = 0.2
    crate = {"mass": 2.0, "inertia": {"box": [side, side, side]}, "material": {"restitution": E, "friction": 0.5},
             "pose": {"position": [0.1, 0.05, TOP + side / 2 + 0.1]}}
    sim = Simulator(_scene({"crate": crate}), "rk4", 1e-2)  # rest is exact at any step: 10 ms keeps it quick
    while not sim.contact.is_resting("crate"):
        sim.step()
        assert sim.time < 2.0
    assert sim.contact.static_body_of(sim.contact.events_of("crate", "rest")[-1].ground) == "table"
    half = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]) * side / 2
    start = sim.time
    worst_gap = worst_speed = 0.0
    while sim.time < start + 10.0:
        sim.step()
        q_WB = quat_multiply(sim.state.q_WP[1], quat_conjugate(sim.model.q_BP[1]))
        corners = sim.state.p_WC_W[1] + quat_rotate(np.broadcast_to(q_WB, (8, 4)), half)
        worst_gap = max(worst_gap, abs(corners[:, 2].min() - TOP))
        worst_speed = max(worst_speed, np.linalg.norm(sim.state.v_WC_W[1]), np.linalg.norm(sim.state.w_WP_P[1]))
    assert worst_gap <= 1e-12 and worst_speed <= 1e-12, (worst_gap, worst_speed)
    assert sim.contact.counts["static_tangent"] == 0
    # held by m g, as reported (rk4 finds the force at every stage; the record is the step start's)
    assert sim.contact.holding_forces[1] == pytest.approx([0.0, 0.0, 2.0 * G], rel=1e-12, abs=1e-12)


# ----------------------------------------------------------------------------- scene

def test_a_body_starting_inside_a_static_shape_is_refused():
    with pytest.raises(SceneError, match=r"bodies\.ball: .*0\.05 m inside static body 'table'"):
        _scene({"ball": _ball([0.0, 0.0, TOP + R - 0.05])})


def test_a_static_body_moved_by_set_body_state_is_met_where_it_now_is():
    """set_body_state of a static body moves its geometry: a ball dropped over the table's new
    place lands on its top at the closed-form time, where it would have fallen past it before."""
    sim = Simulator(_scene({"ball": _ball([3.0, 0.0, 1.0])}), "rk4", 1e-3)
    sim.set_body_state("table", position_world=[3.0, 0.0, 0.0])
    t1 = math.sqrt(2.0 * (1.0 - R - TOP) / G)
    while sim.time < 1.2:  # at rest from t1 (1 + e) / (1 − e) = 1.09 s
        sim.step()
    impact = sim.contact.events_of("ball", "impact")[0]
    assert impact.time == pytest.approx(t1, rel=1e-9) and sim.contact.static_body_of(impact.ground) == "table"
    assert sim.contact.is_resting("ball")
    assert sim.body_state("ball").position_world[2] == pytest.approx(TOP + R, abs=1e-12)


def test_nearest_static_is_the_distance_to_the_static_shape_at_a_pose():
    """query.nearest_static (what refuses a set_state into a static shape): a ball centred d above
    the top face is d − R from it, above a top edge (outside the face) the distance to the edge."""
    from rigid_body_sim.core.contact.query import nearest_static

    sim = Simulator(_scene({"ball": _ball([0.0, 0.0, 2.0])}), "rk4", 1e-3)
    for d in (0.3, R, 0.06):
        dist, static = nearest_static(sim, "ball", [0.1, -0.2, TOP + d], [0.0, 0.0, 0.0, 1.0])
        assert static == "table" and dist == pytest.approx(d - R, abs=1e-12)
    # beside the edge x = 0.5, z = TOP: the centre 0.05 out and 0.05 up is 0.05·√2 from the edge
    dist, _ = nearest_static(sim, "ball", [0.55, 0.0, TOP + 0.05], [0.3, 0.1, 0.0, math.sqrt(0.9)])
    assert dist == pytest.approx(0.05 * math.sqrt(2.0) - R, abs=1e-12)
    assert sim.body_state("ball").position_world[2] == 2.0  # a question: nothing moved


def test_the_example_scene_drops_a_ball_and_a_crate_on_its_table():
    sim = Simulator(load_scene(CONFIG / "contact_static_table.yaml"), "rk4", 1e-3)
    while sim.time < 1.2:
        sim.step()
    h0 = 0.5  # the ball's lowest point above the table top
    t1 = math.sqrt(2.0 * h0 / G)
    first = sim.contact.events_of("ball", "impact")[0]
    assert first.time == pytest.approx(t1, rel=1e-9) and sim.contact.static_body_of(first.ground) == "table"
    assert sim.contact.events_of("ball", "rest")[0].time == pytest.approx(t1 * (1 + E) / (1 - E), abs=1e-6)
    for body in ("ball", "crate"):
        assert sim.contact.is_resting(body)
        assert sim.contact.static_body_of(sim.contact.events_of(body, "rest")[-1].ground) == "table"


def test_a_box_sliding_on_the_floor_into_a_static_wall_rebounds():
    """Frictionless floor, a 0.2 m cube at 2 m/s towards a static wall whose face is 0.8 m ahead of the
    cube's: the impact at t = 0.8 / 2 = 0.4 s, rebound at e v = 1 m/s (the face's normal), still resting on
    the floor."""
    wall = {"mass": 1.0, "inertia": {"box": [0.2, 1.0, 1.0]}, "motion": "static", "pose": {"position": [1.0, 0.0, 0.5]},
            "material": {"restitution": E, "friction": 0.0}}
    crate = {"mass": 1.0, "inertia": {"box": [0.2, 0.2, 0.2]}, "material": {"restitution": E, "friction": 0.0},
             "pose": {"position": [0.0, 0.0, 0.1]}, "twist": {"linear": [2.0, 0.0, 0.0]}}
    sim = Simulator(load_scene({"gravity": [0.0, 0.0, -G], "bodies": {"wall": wall, "crate": crate},
                                "ground": [{"normal": [0, 0, 1], "material": {"restitution": 0.0, "friction": 0.0}}]}),
                    "rk4", 1e-3)
    while sim.time < 0.6:
        sim.step()
    (hit,) = sim.contact.events_of("crate", "impact")
    assert hit.time == pytest.approx(0.4, rel=1e-9) and sim.contact.static_body_of(hit.ground) == "wall"
    assert hit.normal_speed_after == pytest.approx(E * 2.0, rel=1e-9)
    np.testing.assert_allclose(sim.state.v_WC_W[1], [-E * 2.0, 0.0, 0.0], atol=1e-9)
    assert sim.state.p_WC_W[1, 0] == pytest.approx(0.8 - E * 2.0 * (sim.time - 0.4), rel=1e-9)
    assert sim.contact.is_resting("crate") and sim.contact.static_body_of(int(sim.contact.ground_of[1])) is None



#: A 0.1 m cube of a pile settling in its bin (benchmarks/contact_stacks.py), in flight a hair above the ground
#: beside the bin's static wall (its face 4.4e-7 m into it, leaving at 5.6e-5 m/s) and spinning at -1.73 rad/s
#: about the vertical: a state row (position, quaternion w x y z, velocity, angular velocity in its axes).
SPINNING_BY_THE_WALL = [-0.19894649452492108, -0.7999515715289529, 0.05023252783012482, 0.7071039776658533,
                        0.7071055785591859, 0.0013034325100728036, -0.0019916333244841718, 0.09056871771734581,
                        -6.965569379102539e-05, 0.08613935848519019, -1.5286147684083078e-05, 0.003060515819059404,
                        -1.7278594039073631]


def test_a_cube_spinning_on_the_ground_by_a_static_wall_steps_on():
    """The cube above lands on the ground within its first step and, held there, its corner swings into the
    wall while the point that touched it leaves: the impact against the wall is located where that corner
    strikes (after the start), not taken again and again at the step's start (which recursed without end).
    Over 0.2 s: no two of its impacts against the wall at one instant, K + U never above its start."""
    from rigid_body_sim.core.model import State

    box, mat = {"box": [0.1, 0.1, 0.1]}, {"restitution": 0.0, "friction": 0.5}
    cube = {"mass": 1.0, "inertia": box, "collision": box, "material": mat, "pose": {"position": [-0.2, -0.7, 0.2]}}
    wall = {"motion": "static", "mass": 1.0, "inertia": {"box": [1.9, 0.1, 1.0]}, "collision": {"box": [1.9, 0.1, 1.0]},
            "material": mat, "pose": {"position": [0.0, -0.9, 0.5]}}
    sim = Simulator(load_scene({"gravity": [0.0, 0.0, -G], "bodies": {"cube": cube, "wall": wall},
                                "ground": [{"normal": [0, 0, 1], "material": mat}]}), "rk4", 1e-3)
    rows = sim.state.rows().copy()
    rows[0, :13] = SPINNING_BY_THE_WALL
    sim.state = State.of_rows(rows)
    sim.contact.reset(sim)

    def energy() -> float:
        v, w = sim.state.v_WC_W[0], sim.state.w_WP_P[0]
        return 0.5 * v @ v + 0.5 * (1.0 / 600.0) * w @ w + G * sim.state.p_WC_W[0, 2]

    start = energy()
    while sim.time < 0.2:
        sim.step()
        assert energy() <= start + 1e-12 * abs(start)
    times = [e.time for e in sim.contact.events_of("cube", "impact") if sim.contact.static_body_of(e.ground) == "wall"]
    assert times and len(set(times)) == len(times)


#: Bodies of a mixed pile (spheres, boxes, capsules, cylinders, each with its own μ) dropped spinning into a bin of
#: four static walls, each caught at a step that recursed without end: (name, scene body, the bin's inner half-width
#: (m), integrator, dt (s), state row: position, quaternion w x y z, velocity, angular velocity in its axes).
#: A capsule (μ = 0) tumbling at 7.9 rad/s against a wall, barely touching the wall's plane, came back onto it
#: every 1.7e-14 s (struck, at rest, lifted off); a box spinning at 25 rad/s in the corner of a wall and the ground,
#: resting on the wall, was struck against the ground, lifted off and came to rest on the wall again at one
#: instant, and struck against the ground there again.
SPINNING_IN_A_BIN = [
    ("capsule", {"mass": 2.1635159125235983, "inertia": {"cylinder": [0.04786037294547959, 0.13821166275291968]},
                 "collision": {"capsule": [0.04786037294547959, 0.04249091686196049]},
                 "material": {"restitution": 0.0, "friction": 0.0}},
     0.725, "semi_implicit_euler", 1e-3,
     [0.2509382293816587, -0.6722720512218949, 0.0624434906621478, 0.2322631708335445, -0.623191207610753,
      -0.6175726394628818, 0.41986970981228067, 0.07402425702081872, 0.06225986059437048, -4.827916453583656,
      -1.9338207277493131, -2.7783021248310225, 5.264268411018196]),
    ("box", {"mass": 4.358792298649003,
             "inertia": {"box": [0.11153428319655356, 0.052421079813313405, 0.049479990401176316]},
             "collision": {"box": [0.11153428319655356, 0.052421079813313405, 0.049479990401176316]},
             "material": {"restitution": 0.0, "friction": 0.5832559613279641}},
     0.6, "rk4", 1e-3,
     [0.5654378589740209, -0.5435798650455549, 0.0344769051531861, 0.6884222078618908, -0.15775039808776084,
      -0.14516491869125128, 0.6929046269199499, 0.1197366327322956, -0.6718779296824965, -1.3953002391268827,
      11.641253813926262, -20.392985596234006, -9.471857006436267]),
]


def in_a_bin(name: str, body: dict, inner: float, integrator: str, dt: float, row: list) -> Simulator:
    """``body`` alone in a bin of four static walls (0.1 m thick, 1 m high; ``inner``: the half-width inside, m)
    on the ground, set to its state ``row`` (position, quaternion w x y z, velocity, angular velocity in its
    axes), its contact mode found from there."""
    from rigid_body_sim.core.model import State

    mat = {"restitution": 0.0, "friction": 0.6}
    bodies = {name: dict(body, pose={"position": [0.0, 0.0, 0.5]}), **bin_walls(2.0 * inner)}
    sim = Simulator(load_scene({"gravity": [0.0, 0.0, -G], "bodies": bodies,
                                "ground": [{"normal": [0, 0, 1], "material": mat}]}), integrator, dt)
    rows = sim.state.rows().copy()
    rows[0, :13] = row
    sim.state = State.of_rows(rows)
    sim.contact.reset(sim)
    return sim


def steps_on_never_gaining(sim: Simulator, mass: float, seconds: float) -> None:
    """Step body 0 of ``sim`` for ``seconds``: every step taken, the state finite, its K + U never above its
    start (e = 0, gravity the only force)."""
    moments = sim._prm[0, 2:5]

    def energy() -> float:
        v, w = sim.state.v_WC_W[0], sim.state.w_WP_P[0]
        return 0.5 * mass * v @ v + 0.5 * moments @ (w * w) + mass * G * sim.state.p_WC_W[0, 2]

    start = energy()
    while sim.time < seconds:
        sim.step()
        assert np.all(np.isfinite(sim.state.rows()))
        assert energy() <= start + 1e-12 * abs(start)


@pytest.mark.parametrize("name, body, inner, integrator, dt, row", SPINNING_IN_A_BIN,
                         ids=[case[0] for case in SPINNING_IN_A_BIN])
def test_a_body_spinning_against_a_bin_s_wall_steps_on(name, body, inner, integrator, dt, row):
    """Each body above, from its row, over 0.2 s: every step taken (a body struck at an instant is not struck
    against the same plane again at that instant; one that lifts off and comes back at once is held), the state
    finite, K + U never above its start."""
    steps_on_never_gaining(in_a_bin(name, body, inner, integrator, dt, row), body["mass"], 0.2)


def test_a_pebble_sliding_into_a_wall_with_a_half_space_behind_it_is_stepped_once_and_stops_at_the_wall():
    """A pebble (r = 5 mm, e = 0, μ = 0) sliding on the ground at 25 m/s into a bin's wall (e = 0), a second
    half-space's face on the wall's back face, dt = 10 ms (its state in a random scene): its free step ends beyond
    both, so the compiled pass and the static shapes' check both handed it to the solver, and its step was taken
    twice, the second time with the wall it had been struck against at that instant not struck again: it went
    through the wall, struck the half-space and ended 1 cm below the ground. Taken once: it stops at the wall's
    face (e = 0), slides on along it at its speed (frictionless), on the ground. A crate at rest elsewhere leaves room
    in the solver's list of busy bodies, as long as the bodies, for the pebble's second entry (alone, that entry
    was written past the list's end and not read back)."""
    pebble = {"mass": 0.04, "inertia": {"sphere": 0.005}, "material": {"restitution": 0.0, "friction": 0.0},
              "pose": {"position": [0.0, 0.0, 0.5]}}
    crate = {"mass": 1.0, "inertia": {"box": [0.1, 0.1, 0.1]}, "material": {"restitution": 0.0, "friction": 0.5},
             "pose": {"position": [0.5, 0.5, 0.05]}}
    grounds = [{"normal": [0, 0, 1], "offset": 0.0, "material": {"restitution": 0.0, "friction": 0.5}},
               {"normal": [1, 0, 0], "offset": -0.9, "material": {"restitution": 0.8, "friction": 0.3}}]
    bodies = {"pebble": pebble, "crate": crate, **bin_walls(1.6)}
    sim = Simulator(load_scene({"gravity": [0.0, 0.0, -G], "bodies": bodies, "ground": grounds}),
                    "semi_implicit_euler", 0.01)
    p, v = [-0.7286364119448812, -0.40060534155722594, 0.005], [-25.380176101429353, 16.44706799884602, 0.0]
    q_WB = np.array([0.9706284492644083, -0.056240492415934346, 0.03727993358093998, 0.23092775286566103])
    w_B = np.array([0.16797777138780523, -18.777945180308773, 0.9556481573190572])
    sim.set_body_state("pebble", p, q_WB[[1, 2, 3, 0]], v, quat_rotate(q_WB, w_B))
    assert sim.contact.is_resting("pebble")
    sim.step()
    impacts = sim.contact.events_of("pebble", "impact")
    assert [sim.contact.static_body_of(e.ground) for e in impacts] == ["wall_xm"]
    assert impacts[0].time == pytest.approx((-0.795 - p[0]) / v[0], rel=1e-9)
    np.testing.assert_allclose(sim.state.p_WC_W[0], [-0.795, p[1] + 0.01 * v[1], 0.005], rtol=0.0, atol=1e-9)
    np.testing.assert_allclose(sim.state.v_WC_W[0], [0.0, v[1], 0.0], rtol=0.0, atol=1e-9)


@pytest.mark.parametrize("speed", [15.0, 25.0])
@pytest.mark.parametrize("integrator", ["rk4", "semi_implicit_euler"])
def test_a_ball_sliding_along_a_wall_into_the_next_wall_stops_at_its_face(integrator, speed):
    """A ball (r = 4 cm, e = 0, μ = 0) held on the floor and a bin's wall (gravity tilted into both), set sliding
    along their crease at 15 or 25 m/s into the next wall (10 cm thick), dt = 10 ms: it meets the wall's face at
    t0 + (0.8 − r − x0)/V (no force along the crease) and stops there (e = 0). At 15 m/s its end lay beyond the
    wall's middle, and the end's take-in pushed it out through the wall's back face; at 25 m/s its end lay beyond
    the wall, and it was not looked at against it (held on two, the pair screen had not marked it)."""
    r, x0 = 0.04, 0.74
    mat = {"restitution": 0.0, "friction": 0.0}
    ball = {"mass": 1.0, "inertia": {"sphere": r}, "material": mat, "pose": {"position": [x0, -0.8 + r, r]}}
    walls = bin_walls(1.6)
    for wall in walls.values():
        wall["material"] = mat
    sim = Simulator(load_scene({"gravity": [0.0, -G, -G], "bodies": {"ball": ball, **walls},
                                "ground": [{"normal": [0, 0, 1], "material": mat}]}), integrator, 0.01)
    sim.step(2)
    assert sim.contact.is_resting("ball") and sim.contact.other_ground[0] >= 0
    sim.set_body_state("ball", linear_velocity_world=[speed, 0.0, 0.0])
    t0 = sim.time
    sim.step()
    impacts = [e for e in sim.contact.events_of("ball", "impact") if e.time >= t0]
    assert [sim.contact.static_body_of(e.ground) for e in impacts] == ["wall_xp"]
    assert impacts[0].time == pytest.approx(t0 + (0.8 - r - x0) / speed, rel=1e-9)
    np.testing.assert_allclose(sim.state.p_WC_W[0], [0.8 - r, -0.8 + r, r], rtol=0.0, atol=1e-9)
    np.testing.assert_allclose(sim.state.v_WC_W[0], [0.0, 0.0, 0.0], rtol=0.0, atol=1e-9)


@pytest.mark.parametrize("integrator", ["rk4", "semi_implicit_euler"])
def test_a_pebble_sliding_along_one_wall_into_the_next_stops_at_its_face(integrator):
    """A pebble (r = 5 mm, e = 0, μ = 0) on the floor, touching a bin's wall (not pressed on it), set sliding along it
    at 16 m/s into the next wall, dt = 10 ms (its step ends beyond that wall): it meets the wall's face at
    t0 + (0.8 − r − y0)/V and stops there (e = 0). The advancement on its least gap stayed a skin below the wall it
    touched, ran out of samples and trusted the step's end: it went through the next wall."""
    r, y0, speed = 0.005, 0.75, 16.0
    mat = {"restitution": 0.0, "friction": 0.0}
    pebble = {"mass": 0.04, "inertia": {"sphere": r}, "material": mat, "pose": {"position": [-0.8 + r, y0, r]}}
    walls = bin_walls(1.6)
    for wall in walls.values():
        wall["material"] = mat
    sim = Simulator(load_scene({"gravity": [0.0, 0.0, -G], "bodies": {"pebble": pebble, **walls},
                                "ground": [{"normal": [0, 0, 1], "material": mat}]}), integrator, 0.01)
    sim.step(2)
    assert sim.contact.is_resting("pebble") and sim.contact.other_ground[0] < 0
    sim.set_body_state("pebble", linear_velocity_world=[0.0, speed, 0.0])
    t0 = sim.time
    sim.step()
    impacts = [e for e in sim.contact.events_of("pebble", "impact") if e.time >= t0]
    assert [sim.contact.static_body_of(e.ground) for e in impacts] == ["wall_yp"]
    assert impacts[0].time == pytest.approx(t0 + (0.8 - r - y0) / speed, rel=1e-9)
    np.testing.assert_allclose(sim.state.p_WC_W[0], [-0.8 + r, 0.8 - r, r], rtol=0.0, atol=1e-9)
    np.testing.assert_allclose(sim.state.v_WC_W[0], [0.0, 0.0, 0.0], rtol=0.0, atol=1e-9)


def test_a_can_sliding_into_a_corner_of_two_walls_steps_on_pressed_on_them():
    """A can (e = 0.11, μ = 0.64) lying on the ground in a corner of a bin, turning slowly: from its state in a
    mixed pile it slides, stops, strikes one wall, then the other, again and again within one step (each event
    3e-7 to 8e-7 s after the last, each a call deeper), which overflowed Python's stack (RecursionError). Past
    MAX_SIDE_IMPACTS it stays pressed on them for the rest of the step (counted). Then every step is taken over
    0.05 s, K + U never above its start."""
    from rigid_body_sim.core.contact.solver import MAX_SIDE_IMPACTS

    can = {"mass": 3.9281311971888626, "inertia": {"cylinder": [0.04041789711188699, 0.10589070104402448]},
           "material": {"restitution": 0.10809181722129474, "friction": 0.6394651279353796}}
    sim = in_a_bin("can", can, 0.475, "semi_implicit_euler", 1e-3,
                   [0.4116255016963475, -0.4300008867716222, 0.055251363544712134, -0.5622423238572807,
                    -0.13938854783009236, 0.8004857041173038, 0.15387345287997994, 0.0034729966473030795,
                    -0.0003300040652187259, -0.0023490778389728658, -0.02686796787891014, 0.0571395587766255,
                    2.5902936145249885e-17])
    sim.step()
    walls = [e for e in sim.contact.events_of("can", "impact") if sim.contact.static_body_of(e.ground) is not None]
    assert len(walls) >= MAX_SIDE_IMPACTS and sim.contact.counts["side_pressed"] == 1
    steps_on_never_gaining(sim, can["mass"], 0.05)


def test_a_box_sliding_into_a_corner_of_two_walls_ends_no_step_inside_either():
    """A box (1.45 kg, 55 × 193 × 76 mm, frictionless, e = 0) sliding flat on the ground at 3.2 m/s, turning at
    2.9 rad/s, into a corner of a bin (rk4, dt = 5 ms; its state in a mixed pile): it strikes one wall, stays pressed
    on it, slides along it into the other and strikes that one, then each again. A static shape a body stays pressed
    on is left out of its step's view, that one only: the other wall is still met. Over 0.2 s no step ends with the
    box inside either wall (1e-9 m), and K + U never rises above its start."""
    from rigid_body_sim.core.contact.query import overlapping_bodies

    box = {"mass": 1.4531924504361775, "inertia": {"box": [0.05534714537040836, 0.19278692858386087, 0.07639080722491805]},
           "material": {"restitution": 0.0, "friction": 0.0}}
    sim = in_a_bin("box", box, 0.725, "rk4", 5e-3,
                   [0.620211282232623, 0.6162672910330871, 0.027673572685204186, 0.6280062139951152,
                    -0.32497414540778713, 0.6280062139951151, 0.3249741454077872, 2.1251706194112705, 2.360445442696648,
                    0.0, 2.9394675984516736, 0.0, 0.0])
    moving = np.array([m != "static" for m in sim.model.motions])

    def energy() -> float:
        v, w = sim.state.v_WC_W[0], sim.state.w_WP_P[0]
        return 0.5 * box["mass"] * v @ v + 0.5 * sim._prm[0, 2:5] @ (w * w) + box["mass"] * G * sim.state.p_WC_W[0, 2]

    start = energy()
    while sim.time < 0.2:
        sim.step()
        overlaps = overlapping_bodies(sim.positions_world(), sim.orientations_xyzw()[:, [3, 0, 1, 2]],
                                      sim.contact.shapes, moving)
        assert all(depth <= 1e-9 for *_, depth in overlaps), overlaps
        assert energy() <= start + 1e-12 * abs(start)
    assert sim.contact.counts["static_pressed"] >= 1


def test_a_box_turning_on_the_ground_into_a_corner_of_two_walls_is_held_on_one_and_ends_no_step_inside_either():
    """A box (0.58 kg, 52 × 187 × 110 mm, μ = 0.54, e = 0) sliding on the ground at 0.69 m/s into a corner of a bin,
    turning at 6.5 rad/s (rk4, dt = 5 ms; its state in a mixed pile). Struck against a wall and staying on it, it is
    held on the ground and that wall's face together (two_grounds.py); a wall it is pressed on but not held on
    is out of the rest of its step's view, and the box is taken out of it at the step's end. Over 0.1 s no step
    ends with the box inside either wall (1e-9 m), and K + U never rises above its start."""
    box = {"mass": 0.5787400912131158,
           "inertia": {"box": [0.051731844232701205, 0.1873574680605085, 0.10973606564341284]},
           "material": {"restitution": 0.0, "friction": 0.5449202178297207}}
    sim = in_a_bin("box", box, 0.475, "rk4", 5e-3,
                   [0.40239587041739766, -0.40972221741861675, 0.10436193709050023, 0.25816485627327235,
                    -0.06321241399260667, 0.6482191426183491, -0.7135594164789365, 0.12486473506382093,
                    -0.6474824946141121, -0.23858259426007616, -6.126942533133614, 0.8025537328525567,
                    2.1209437228761985])
    held_on = ends_no_step_inside_anything(sim, box["mass"], 0.1)
    assert held_on and None not in held_on  # held on a wall's face, beside the ground


def ends_no_step_inside_anything(sim: Simulator, mass: float, seconds: float) -> set:
    """Step body 0 of ``sim`` for ``seconds``: no step ends with it inside another body or the ground (1e-9 m), its
    K + U never above its start (e = 0, gravity the only force). Returns the static bodies it was held on beside
    its ground (two_grounds.py) at the ends of steps (None for a half-space)."""
    from rigid_body_sim.core.contact.query import lowest_gaps, overlapping_bodies

    moving = np.array([m != "static" for m in sim.model.motions])

    def energy() -> float:
        v, w = sim.state.v_WC_W[0], sim.state.w_WP_P[0]
        return 0.5 * mass * v @ v + 0.5 * sim._prm[0, 2:5] @ (w * w) + mass * G * sim.state.p_WC_W[0, 2]

    start, held_on = energy(), set()
    while sim.time < seconds:
        sim.step()
        overlaps = overlapping_bodies(sim.positions_world(), sim.orientations_xyzw()[:, [3, 0, 1, 2]],
                                      sim.contact.shapes, moving)
        assert all(depth <= 1e-9 for *_, depth in overlaps), (sim.time, overlaps)
        assert float(lowest_gaps(sim)[0]) >= -1e-9, sim.time
        assert energy() <= start + 1e-12 * abs(start)
        if sim.contact.other_ground[0] >= 0:
            held_on.add(sim.contact.static_body_of(int(sim.contact.other_ground[0])))
    return held_on


def test_a_box_leaning_on_an_edge_in_a_corner_of_the_ground_and_a_wall_ends_no_step_inside_either():
    """A box (2.06 kg, 153 × 84 × 198 mm, μ = 0.17, e = 0) coming down edge first, spinning, into a corner of the
    ground and a bin's wall (semi-implicit Euler, dt = 10 ms; its state in a mixed pile). It comes to lean there on
    an edge, held on the ground and the wall's face together. Projecting each step's end onto one and then the
    other, repeated, reaches the projection onto both only slowly here (their rows nearly parallel in the box's
    mass metric: 60 rounds left a corner 83 µm in the ground), so after 8 rounds it is projected onto both at once.
    Over 0.1 s no step ends with the box inside the ground or the wall (1e-9 m), and K + U never rises above its
    start."""
    box = {"mass": 2.0593700261059396,
           "inertia": {"box": [0.15253527789245844, 0.08433672764143352, 0.19841347122369116]},
           "material": {"restitution": 0.0, "friction": 0.1733344631478857}}
    sim = in_a_bin("box", box, 0.6, "semi_implicit_euler", 1e-2,
                   [-0.5066597060941107, -0.39592926203385076, 0.11486829040739491, 0.1615877757612124,
                    0.01057794604074107, -0.15531517104913561, -0.974502280871667, -0.6411512812084411,
                    -0.16577607678379205, -1.365144870859098, -4.966237700773998, -6.6022460896078154,
                    -1.4692920810831582])
    held_on = ends_no_step_inside_anything(sim, box["mass"], 0.1)
    assert held_on and None not in held_on  # held on a wall's face, beside the ground


def test_a_can_on_its_side_rolling_into_a_wall_ends_no_step_inside_it():
    """A can (3.0 kg, r = 36 mm, 231 mm long, frictionless, e = 0) lying on its side on the ground, rolling and
    turning into a bin's wall (rk4, dt = 10 ms; its state in a mixed pile). The wall it is pressed on is out of the
    rest of its step's view, and the can is taken out of it at the step's end: both rims, the one the projection
    turns in as it lifts the other. Over 0.1 s no step ends with the can inside the wall (1e-9 m), and K + U never
    rises above its start."""
    can = {"mass": 2.986577353445401, "inertia": {"cylinder": [0.036439462878206534, 0.11557833235285284]},
           "material": {"restitution": 0.0, "friction": 0.0}}
    sim = in_a_bin("can", can, 0.6, "rk4", 1e-2,
                   [-0.089968345548037, 0.5605030193659176, 0.036439462878206534, -0.37814043286538457,
                    0.6168550370185681, -0.34567305840175183, 0.5975029816096148, 0.019535211445958628,
                    0.13067163016700784, 0.0, -1.1418210529139667, 2.111207014662922, 1.185969834757766])
    ends_no_step_inside_anything(sim, can["mass"], 0.1)


def test_a_box_resting_on_a_wall_s_top_edge_sliding_into_the_next_wall_is_not_moved_into_it():
    """A box (3.68 kg, 81 × 153 × 45 mm, μ = 0.22, e = 0) resting tilted on the top inner edge of a bin's wall, held on
    the edge's tangent plane, sliding along it at 0.31 m/s into the corner with the next wall (rk4, dt = 1 ms; its
    state in a mixed pile). Its plane is refreshed against the wall it rests on; when the next wall is nearer it
    lifts off and its flight meets whichever it reaches. (The plane, refreshed against the nearest wall, became the
    next wall's while the features held were the first's, and the box was moved 7 cm into the walls in one step,
    its K + U up 1.6 J.) Over 0.3 s it is never deeper in a wall than its one step's travel (0.32 mm: a body held on
    a static shape meets another one a step late), never moved more than that off its free step, and K + U never
    rises above its start."""
    box = {"mass": 3.6849575813438182, "inertia": {"box": [0.08125638450646401, 0.15314557870419326, 0.04492328466994563]},
           "collision": {"box": [0.08125638450646401, 0.15314557870419326, 0.04492328466994563]},
           "material": {"restitution": 0.0, "friction": 0.21606845625622342}}
    row = [0.6514907690227308, -0.6827874718254205, 1.008888506149661, 0.043857384584905935, 0.2553983188692946,
           0.95190759708085, -0.1634630085244726, 0.3086456814530568, 0.08219034341985552, -0.029085377155726504, 0.0,
           2.7755575615628914e-17, -0.1950644254744148]
    sim = in_a_bin("box", box, 0.725, "rk4", 1e-3, row)
    assert sim.contact.modes[0] == PERSISTENT and sim.contact.statics.is_tangent(int(sim.contact.ground_of[0]))
    moving = np.array([m != "static" for m in sim.model.motions])
    travel = np.linalg.norm(row[7:10]) * sim.dt

    def energy() -> float:
        v, w = sim.state.v_WC_W[0], sim.state.w_WP_P[0]
        return 0.5 * box["mass"] * v @ v + 0.5 * sim._prm[0, 2:5] @ (w * w) + box["mass"] * G * sim.state.p_WC_W[0, 2]

    start = energy()
    while sim.time < 0.3:
        p0, v0 = sim.state.p_WC_W[0].copy(), sim.state.v_WC_W[0].copy()
        sim.step()
        assert np.linalg.norm(sim.state.p_WC_W[0] - p0 - v0 * sim.dt) <= travel
        overlaps = overlapping_bodies(sim.positions_world(), sim.orientations_xyzw()[:, [3, 0, 1, 2]],
                                      sim.contact.shapes, moving)
        assert all(depth <= travel for *_, depth in overlaps), overlaps
        assert energy() <= start + 1e-12 * abs(start)
    assert sim.contact.counts["static_tangent"] > 0


def test_a_box_lying_across_a_bin_s_corner_on_two_walls_top_edges_ends_no_step_inside_either():
    """A box (2.65 kg, 42 × 118 × 153 mm, μ = 0.90, e = 0.04) lying across a corner of a bin on the top inner edges
    of its two walls (rk4, dt = 5 ms; its state in a mixed pile). Held on one edge's tangent plane, it does not see
    the other wall within its step: each step took it into the other wall, and the next, finding that one nearer,
    held it there and took it into the first (up to 0.18 mm). At each step's end it is taken out of another static
    shape it went into, through the tangent plane of their contact. Over 0.1 s no step ends with it inside either
    wall (1e-9 m), and K + U never rises above its start."""
    box = {"mass": 2.650458858285881, "inertia": {"box": [0.04207934160487229, 0.1182257399723185, 0.15277238918538757]},
           "material": {"restitution": 0.042472458454032413, "friction": 0.8953977138373029}}
    sim = in_a_bin("box", box, 0.85, "rk4", 5e-3,
                   [-0.8118045561949755, 0.770461083275929, 1.0475793740855877, 0.606529497076377, -0.675198819541459,
                    -0.02874726085821201, -0.41881036073531813, -0.5581560963747597, 0.43627940620947264,
                    -2.1562882603467046, -2.178864297395131, -5.140156642341217, -4.624026556167017])
    ends_no_step_inside_anything(sim, box["mass"], 0.1)
    assert sim.contact.counts["static_tangent"] > 0 and sim.contact.counts["static_taken_out"] > 0


def test_a_can_standing_against_a_wall_is_never_thrown_by_its_held_force():
    """A squat can (r 46 mm, 46 mm long) standing on its end against a bin's wall, tilted 2.6e-7 rad, at rest
    (rk4, dt = 10 ms): its held step, on a rim point, spun it up to 3.4e5 rad/s (K + U up 3e7 J) and blew the pile
    it stood in up. A held step that raises a can's K + U under gravity alone by more than THROWN of it on its rim is
    its end face landing instead (counted), as for a rim piece: over 0.5 s it never turns faster than 1e-3 rad/s and
    K + U never rises."""
    can = {"mass": 0.6871287265198777, "inertia": {"cylinder": [0.04629392476346544, 0.0461623652861889]},
           "material": {"restitution": 0.0, "friction": 0.7954485937657689}}
    sim = in_a_bin("can", can, 0.85, "rk4", 1e-2,
                   [0.8037058781713039, -0.6057061431785316, 0.023081206365903977, 0.8420407349763931,
                    -8.265963422096969e-08, 2.424981508906366e-07, -0.5394139418297883, -1.0263751533643903e-12,
                    -8.887006138571058e-06, 9.879142650439116e-14, 1.1928655409217033e-10, 1.5283245592492018e-10,
                    -0.00037597601170864835])
    steps_on_never_gaining(sim, can["mass"], 0.5)
    assert np.linalg.norm(sim.state.w_WP_P[0]) <= 1e-3
    assert sim.contact.counts["face_landed"] >= 1



def test_a_spinning_can_thrown_at_a_static_wall_stays_out_of_it():
    """A can (r 50 mm, 156 mm long, 4 kg) on its rim, spinning at 10 rad/s, thrown at a static wall at 0.62 m/s
    (a can's state in a mixed pile; rk4, dt = 1 ms). A step of it taken again in pieces (its energy had risen) met
    the wall, and was then stepped once more from its start, as a body near a static shape, with the wall skipped
    (the step taken again had left the can pressed on it): it went 2.4 cm into the wall. Over 0.2 s it never
    reaches more than 1e-5 m into the wall or the floor (a h²/2 for a up to 20 m/s²), and its K + U never rises."""
    can = {"cylinder": [0.049560408747222576, 0.07799828717481329]}
    wall = {"box": [1.15, 0.1, 1.0]}
    bodies = {"can": {"mass": 3.9627730109766923, "inertia": can, "collision": can,
                      "material": {"restitution": 0.0, "friction": 0.9093106554938208},
                      "pose": {"position": [0.40614626503862417, -0.4085399449585262, 0.06160683441638553],
                               "orientation": [0.8369991005654008, -0.13221949997652288, 0.3370129644885506,
                                               0.41033251302487317]},
                      "twist": {"linear": [-0.055372066842075185, -0.6175551597125589, 0.11040546795891806],
                                "angular": [9.630362370672978, -0.22816879286822656, 3.5536849834932283]}},
              "wall": {"motion": "static", "mass": 1.0, "inertia": wall, "collision": wall,
                       "material": {"restitution": 0.0, "friction": 0.5}, "pose": {"position": [0.0, -0.525, 0.5]}}}
    sim = Simulator(load_scene({"gravity": [0.0, 0.0, -G], "bodies": bodies,
                                "ground": [{"normal": [0, 0, 1], "material": {"restitution": 0.0, "friction": 0.6}}]}),
                    "rk4", 1e-3, threads=1)
    moving = np.array([True, False])

    def energy() -> float:
        return float(sim.kinetic_energy()[0] + sim.potential_energy()[0])

    start = energy()
    for _ in range(200):
        sim.step()
        q = sim.orientations_xyzw()[:, [3, 0, 1, 2]]
        overlaps = overlapping_bodies(sim.positions_world(), q, sim.contact.shapes, moving)
        assert not overlaps or overlaps[0][2] <= 1e-5
        assert float(lowest_gaps(sim)[0]) >= -1e-5
        assert energy() <= start + 1e-12 * abs(start)
    assert sim.contact.counts["refined_steps"] >= 1

def test_a_ball_rising_into_a_corner_of_two_walls_is_struck_against_the_walls():
    """A frictionless ball (e = 0) touching the ground and two walls of a bin's corner, rising off the ground at
    0.041 m/s and rolling into both walls (a mixed pile's ball just struck by another body): each wall stops its
    motion into it (the impacts are against the walls, at the start; after the step it moves into neither), where
    it was struck against the ground (the tie of the lowest gap went to it; it moves away from it) again and again,
    10,000 times in one step.
    Then every step taken over 0.2 s, K + U never above its start (semi-implicit Euler, dt = 5 ms)."""
    ball = {"mass": 1.5951765266201263, "inertia": {"sphere": 0.07374914567620969},
            "material": {"restitution": 0.0, "friction": 0.0}}
    sim = in_a_bin("ball", ball, 0.6, "semi_implicit_euler", 5e-3,
                   [-0.5262508543237903, -0.5262508543237903, 0.07374914567620969, -0.9300226372947686,
                    -0.050534643597118345, 0.24044832017446707, 0.2732924244121538, -0.0893601595778491,
                    -0.09534841331544075, 0.04099347814488298, -0.12601043460693118, 4.127391555715792,
                    0.28697309671209986])
    sim.step()
    struck = {sim.contact.static_body_of(e.ground) for e in sim.contact.events_of("ball", "impact")}
    assert struck == {"wall_xm", "wall_ym"}
    v = sim.state.v_WC_W[0]
    assert v[0] >= -1e-12 and v[1] >= -1e-12  # into neither wall (they are at x, y = −0.6 m)
    steps_on_never_gaining(sim, ball["mass"], 0.2)

def test_resting_on_a_static_ball_is_held_on_its_tangent_plane_and_counted():
    """Not covered exactly (a curved support): held on the tangent plane, refreshed each step, counted.
    At the apex that plane is level: the ball stays there (the equilibrium), gap 0."""
    post = {"mass": 1.0, "inertia": {"sphere": 0.3}, "motion": "static", "pose": {"position": [0.0, 0.0, 1.0]},
            "material": {"restitution": 0.0, "friction": 0.5}}
    ball = {"mass": 1.0, "inertia": {"sphere": R}, "pose": {"position": [0.0, 0.0, 1.6]}}
    sim = Simulator(load_scene({"gravity": [0.0, 0.0, -G], "ground": [], "bodies": {"post": post, "ball": ball}}),
                    "rk4", 1e-3)
    while sim.time < 0.5:
        sim.step()
    assert sim.contact.is_resting("ball")
    assert sim.contact.counts["static_tangent"] > 0
    assert abs(sim.state.p_WC_W[1, 2] - 1.4) <= 1e-12 and np.abs(sim.state.v_WC_W[1]).max() <= 1e-12


# ----------------------------------------------------------------------------- per-body materials

def _drop_onto(centre, reach, offset_W, height):
    """A body dropped from rest with its centre ``height`` above a static centre (or axis point) ``centre``,
    ``offset_W`` (horizontal, m) off it: (start, impact time, velocity at the impact, unit normal there), for
    contact when the centres are ``reach`` apart (sphere on sphere, or on a capsule's axis)."""
    offset_W = np.asarray(offset_W, float)
    rise = math.sqrt(reach * reach - offset_W @ offset_W)  # the centre's height above ``centre`` at the impact
    t = math.sqrt(2.0 * (height - rise) / G)
    start = np.asarray(centre, float) + offset_W + [0.0, 0.0, height]
    return start, t, np.array([0.0, 0.0, -G * t]), (offset_W + [0.0, 0.0, rise]) / reach


def test_each_body_meets_static_shapes_with_its_own_pair_material():
    """Four bodies, four materials, one scene: two crates launched at 1 m/s on a static box's top face stop
    at t = v/(μ g) after v²/(2 μ g) with their own pair's μ = √(μ_body μ_box) (a face row); two balls
    dropped onto a static ball and a static capsule (their tangent rows) get the closed-form impact
    (exact/sphere_impact.py with the static side of infinite mass) of their own pair's e = max(e_body,
    e_static), μ = √(μ_body μ_static) at the closed-form time: one slides through the impact (45°,
    tan θ > 3.5 μ), the other sticks. rk4, dt = 1 ms: parabolas and the constant friction are exact for
    it, the events are located on the step map: 1e-9 relative."""
    from rigid_body_sim.exact.sphere_impact import two_sphere_impact

    table_e, table_mu = 0.3, 0.5
    crates = {"crate_a": (0.1, 0.2, 0.25), "crate_b": (0.7, 0.8, -0.25)}  # e, μ, y on the table
    post_centre, post_r, post_e, post_mu = np.array([3.0, 0.0, 0.0]), 0.3, 0.6, 0.4
    rail_centre, rail_r, rail_e, rail_mu = np.array([-3.0, 0.0, 0.0]), 0.1, 0.5, 0.3
    balls = {  # e, μ, the static body, its centre (the capsule's axis point below), reach, horizontal offset, height
        "ball_c": (0.8, 0.1, "post", post_centre, post_r + R, (0.4 * math.sqrt(0.5), 0.0, 0.0), 1.0),  # θ = 45°
        "ball_d": (0.2, 0.9, "rail", rail_centre, rail_r + R, (0.0, 0.2 / math.sqrt(5.0), 0.0), 0.8),  # tan θ = 0.5
    }
    static_materials = {"post": (post_e, post_mu), "rail": (rail_e, rail_mu)}
    bodies = {
        "table": {"mass": 10.0, "inertia": {"box": [1.0, 1.0, 0.5]}, "motion": "static",
                  "material": {"restitution": table_e, "friction": table_mu}},
        "post": {"mass": 1.0, "inertia": {"sphere": post_r}, "motion": "static",
                 "pose": {"position": list(post_centre)}, "material": {"restitution": post_e, "friction": post_mu}},
        "rail": {"mass": 1.0, "inertia": {"sphere": rail_r}, "collision": {"capsule": [rail_r, 1.6]},
                 "motion": "static", "material": {"restitution": rail_e, "friction": rail_mu},  # axis along world x
                 "pose": {"position": list(rail_centre), "orientation": [0.0, math.sqrt(0.5), 0.0, math.sqrt(0.5)]}},
    }
    v0 = 1.0
    for name, (e, mu, y) in crates.items():
        bodies[name] = {"mass": 1.0, "inertia": {"box": [0.1, 0.1, 0.1]},
                        "material": {"restitution": e, "friction": mu},
                        "pose": {"position": [-0.3, y, TOP + 0.05]}, "twist": {"linear": [v0, 0.0, 0.0]}}
    drops = {}
    for name, (e, mu, _, centre, reach, offset, height) in balls.items():
        drops[name] = _drop_onto(centre, reach, offset, height)
        bodies[name] = {"mass": 1.0, "inertia": {"sphere": R}, "material": {"restitution": e, "friction": mu},
                        "pose": {"position": list(drops[name][0])}}
    sim = Simulator(load_scene({"gravity": [0.0, 0.0, -G], "ground": [], "bodies": bodies}), "rk4", 1e-3)
    names = sim.model.names
    sim.step(600)
    contact = sim.contact
    for name, (e, mu, _) in crates.items():
        i = names.index(name)
        mu_pair = math.sqrt(mu * table_mu)
        (stop,) = contact.events_of(name, "stick")
        assert stop.time == pytest.approx(v0 / (mu_pair * G), rel=1e-9)
        assert sim.state.p_WC_W[i, 0] == pytest.approx(-0.3 + v0 * v0 / (2.0 * mu_pair * G), rel=1e-9)
        j = int(contact.ground_of[i])
        assert contact.is_resting(name) and contact.static_body_of(j) == "table" and not contact.statics.is_tangent(j)
        assert contact.friction_of(i, j) == pytest.approx(mu_pair, rel=1e-15)
        assert contact.restitution_of(i, j) == max(e, table_e)
    slid = {}
    for name, (e, mu, static, _, reach, _, _) in balls.items():
        i = names.index(name)
        _, t_hit, v_hit, n = drops[name]
        e_static, mu_static = static_materials[static]
        e_pair, mu_pair = max(e, e_static), math.sqrt(mu * mu_static)
        # a ball sticks through the impact while |u_t| ≤ (1 + m R²/I) μ |u_n| = 3.5 μ |u_n|
        slid[name] = np.linalg.norm(np.cross(n, v_hit)) > 3.5 * mu_pair * abs(n @ v_hit)
        hit = contact.events_of(name, "impact")[0]
        assert hit.time == pytest.approx(t_hit, rel=1e-9)
        assert contact.static_body_of(hit.ground) == static and contact.statics.is_tangent(hit.ground)
        assert hit.ground == contact.statics.first_tangent + i  # its own tangent row
        assert contact.restitution_of(i, hit.ground) == e_pair
        assert contact.friction_of(i, hit.ground) == pytest.approx(mu_pair, rel=1e-15)
        inertia = 0.4 * R * R
        _, _, v_after, w_after = two_sphere_impact(math.inf, math.inf, reach - R, np.zeros(3), np.zeros(3), 1.0,
                                                   inertia, R, v_hit, np.zeros(3), n, e_pair, mu_pair)
        scale = np.linalg.norm(v_hit)
        np.testing.assert_allclose(v_hit + hit.delta_v_world, v_after, rtol=0.0, atol=1e-9 * scale)
        np.testing.assert_allclose(quat_rotate(np.array(hit.q_WP), np.array(hit.delta_w_principal)), w_after,
                                   rtol=0.0, atol=1e-9 * scale / R)
        assert hit.normal_speed_after == pytest.approx(-e_pair * hit.normal_speed_before, rel=1e-9)
    assert slid == {"ball_c": True, "ball_d": False}  # both branches of the impact's cone: a slide, a stick


def test_static_shape_materials_are_linear_in_the_bodies():
    """2,000 balls, each with its own material, resting apart on a static box (a bin's floor), the last one on
    a static ball: every array the static geometry holds is linear in the bodies (≤ 512 bytes a body, where
    one n × n array of floats would hold 16 kB a body; the
    materials n × (G + 6 per static box) and n for the tangent rows, G = 0 here), and each body's materials
    are its pair material with the shape it touches (e = max, μ = √ of the product): the floor's face row,
    the static ball's tangent row (written at the start for the ball on it, and for every body by the
    island contacts' plane_rows)."""
    rng = np.random.default_rng(0)
    nx, ny, pitch = 50, 40, 0.2
    count = nx * ny
    e, mu = rng.uniform(0.0, 1.0, count), rng.uniform(0.0, 1.0, count)
    floor_e, floor_mu, post_e, post_mu = 0.3, 0.6, 0.7, 0.2
    post_centre = np.array([0.5 * pitch * nx + 2.0, 0.0, 0.2])
    bodies = {"floor": {"mass": 1.0, "inertia": {"box": [pitch * nx + 1.0, pitch * ny + 1.0, 0.1]},
                        "motion": "static", "pose": {"position": [0.0, 0.0, -0.05]},
                        "material": {"restitution": floor_e, "friction": floor_mu}},
              "post": {"mass": 1.0, "inertia": {"sphere": 0.2}, "motion": "static",
                       "pose": {"position": list(post_centre)},
                       "material": {"restitution": post_e, "friction": post_mu}}}
    radius = 0.05
    for k in range(count):
        position = [pitch * (k % nx - 0.5 * (nx - 1)), pitch * (k // nx - 0.5 * (ny - 1)), radius]
        if k == count - 1:  # the last one on top of the static ball
            position = list(post_centre + [0.0, 0.0, 0.2 + radius])
        bodies[f"b{k}"] = {"mass": 1.0, "inertia": {"sphere": radius},
                           "material": {"restitution": float(e[k]), "friction": float(mu[k])},
                           "pose": {"position": position}}
    sim = Simulator(load_scene({"gravity": [0.0, 0.0, -G], "ground": [], "bodies": bodies}), "rk4", 1e-3)
    contact, statics = sim.contact, sim.contact.statics
    n, faces = sim.model.count, 6  # one static box
    assert statics.restitution.shape == statics.friction.shape == (n, faces)
    assert statics.tangent_restitution.shape == statics.tangent_friction.shape == (n,)
    held = sum(a.nbytes for a in vars(statics).values() if isinstance(a, np.ndarray))
    assert held <= 512 * n, f"{held / n:.0f} bytes a body"
    index = {name: i for i, name in enumerate(sim.model.names)}
    moving = np.array([index[f"b{k}"] for k in range(count)])
    floor_e_pair, floor_mu_pair = np.maximum(e, floor_e), np.sqrt(mu * floor_mu)
    post_e_pair, post_mu_pair = np.maximum(e, post_e), np.sqrt(mu * post_mu)
    assert np.all(contact.modes[moving] == PERSISTENT)  # every ball touches its support: resting on it
    on_floor, last = moving[:-1], int(moving[-1])
    floor_rows = contact.ground_of[on_floor]
    assert np.all(floor_rows == statics.first_face[0] + 4)  # the floor's +z face
    np.testing.assert_array_equal([contact.restitution_of(i, j) for i, j in zip(on_floor, floor_rows)],
                                  floor_e_pair[:-1])
    np.testing.assert_allclose([contact.friction_of(i, j) for i, j in zip(on_floor, floor_rows)],
                               floor_mu_pair[:-1], rtol=1e-15)
    assert contact.ground_of[last] == statics.first_tangent + last
    assert contact.restitution_of(last, statics.first_tangent + last) == post_e_pair[-1]
    assert contact.friction_of(last, statics.first_tangent + last) == pytest.approx(post_mu_pair[-1], rel=1e-15)
    # every body's tangent row written against the static ball (as island_contacts.py does for an island's body)
    normals = np.tile([1.0, 0.0, 0.0], (count, 1))
    post = np.full(count, index["post"])
    rows = statics.plane_rows(moving, post, normals, post_centre + 0.2 * normals)
    np.testing.assert_array_equal(rows, statics.first_tangent + moving)
    np.testing.assert_array_equal([contact.restitution_of(i, j) for i, j in zip(moving, rows)], post_e_pair)
    np.testing.assert_allclose([contact.friction_of(i, j) for i, j in zip(moving, rows)], post_mu_pair, rtol=1e-15)
