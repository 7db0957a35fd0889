"""What a force costs from Python, per frame, and one body driven per step beside MuJoCo's site actuator.

The body: the 2 kg 1.0 × 0.6 × 0.4 m box ``b``, spinning at ω = (0.3, 1.0, 0.2) rad/s, no
gravity, h = 1 ms, with two sites at the corner (0.5, 0.3, 0) m: ``corner`` (body axes) and
``corner_w`` (world axes). Each call gets a new force: (0, ±10, 0) N alternating (and for
``apply_wrench`` a torque (0, 0, ±1) N·m), given as (3,) numpy arrays as a controller computing
with numpy hands them over (alternating, so the body never spins up however many steps a
sample takes).

(i) **Per-frame cost** of ``apply_force_at_point`` and ``apply_wrench`` (integrator ``rk4``), in
the frames of the frame rule: ``world`` (the corner as a world point), ``b/world_aligned``
(the corner offset in world axes), ``b`` (the corner in body axes), ``b/corner`` (a site with
body axes, at its origin), ``b/corner_w`` (a site with world axes). Three figures each:

* ``call``: one call, k calls in a row (they accumulate; no step between);
* ``apply + step(1)``: one call then ``sim.step(1)``, as a controller does every step;
* ``over step(1)``: that minus ``step(1)`` with no wrench (same run) — what the wrench adds
  to a step, its resolution inside the step included.

MuJoCo reference rows beside them: ``d.xfrc_applied[1, :3] = F; mj_step(m, d)`` (a force at
the COM in world axes, the match of ``b/world_aligned``) and ``d.ctrl[0] = f; mj_step(m, d)``
with a motor on a site (the match of ``b/corner``); RK4.

(ii) **One body, a new site-frame force every step from Python**: ours
``sim.apply_force_at_point("b", F, (0, 0, 0), frame="b/corner"); sim.step(1)`` against MuJoCo's
``d.ctrl[0] = f; mujoco.mj_step(m, d)`` with ``<motor site="s0" gear="0 1 0 0 0 0"/>`` on the same
corner, for each matched pair (semi_implicit_euler ↔ Euler, implicit_gyroscopic ↔
implicitfast, rk4 ↔ RK4); ``step(1)`` and ``mj_step`` alone beside them. For the matched
integrators also the control array, MuJoCo's own idiom on our side: ``u = sim.control("b",
"b/corner")`` once, then ``u[1] = f; sim.step(1)`` every step (the force along the site's y
axis, as MuJoCo's motor gear), in the same interleaved run.
"""

from __future__ import annotations

import numpy as np

from rigid_body_sim.core import INTEGRATORS, Simulator, load_scene

from . import mujoco_models as mjm
from .throughput import ANGULAR_VELOCITY, DT, INERTIA_BOX, MASS, SIDES
from .timing import Case, interleaved

CORNER_B = (0.5, 0.3, 0.0)  # m, body axes from the COM
FORCE = 10.0                # N
#: (label, frame name, point in that frame for apply_force_at_point) — the same physical force at t = 0.
FRAMES = (
    ("world", "world", CORNER_B),
    ("<body>/world_aligned", "b/world_aligned", CORNER_B),
    ("<body>", "b", CORNER_B),
    ("site, body axes", "b/corner", (0.0, 0.0, 0.0)),
    ("site, world axes", "b/corner_w", (0.0, 0.0, 0.0)),
)
FUNCTIONS = ("apply_force_at_point", "apply_wrench")
INTEGRATOR = "rk4"  # the default; MuJoCo rows use RK4


def scene():
    """The box with its two corner sites."""
    return load_scene({"bodies": {"b": {
        "mass": MASS, "inertia": {"box": list(SIDES)},
        "twist": {"angular": ANGULAR_VELOCITY.tolist()},
        "sites": {"corner": {"position": list(CORNER_B)}, "corner_w": {"position": list(CORNER_B), "axes": "world"}},
    }}})


def _forces() -> tuple[np.ndarray, np.ndarray]:
    return np.array([0.0, FORCE, 0.0]), np.array([0.0, -FORCE, 0.0])


def _our_cases(sim: Simulator, function: str, frame: str, point, tag=()) -> list[Case]:
    """Cases ``tag + (function, frame, "call")`` and ``tag + (function, frame, "apply + step(1)")``."""
    forces = _forces()
    torques = (np.array([0.0, 0.0, 1.0]), np.array([0.0, 0.0, -1.0]))
    label = tag + (function, frame)
    if function == "apply_force_at_point":
        apply = sim.apply_force_at_point

        def call(i: int) -> None:
            apply("b", forces[i & 1], point, frame)
    else:
        apply_w = sim.apply_wrench

        def call(i: int) -> None:
            apply_w("b", forces[i & 1], torques[i & 1], frame)

    def calls(k: int) -> None:
        for i in range(k):
            call(i)

    step = sim.step

    def with_step(k: int) -> None:
        for i in range(k):
            call(i)
            step(1)
    return [Case(label + ("call",), calls, sim.reset), Case(label + ("apply + step(1)",), with_step, sim.reset)]


def _bare_step(sim: Simulator, key) -> Case:
    step = sim.step

    def run(k: int) -> None:
        for _ in range(k):
            step(1)
    return Case(key, run, sim.reset)


def _control_case(sim: Simulator, key) -> Case:
    """``u[1] = ±FORCE; step(1)`` through the control row of the corner site (Simulator.control)."""
    u = sim.control("b", "b/corner")
    step = sim.step
    values = (FORCE, -FORCE)

    def run(k: int) -> None:
        for i in range(k):
            u[1] = values[i & 1]
            step(1)
    return Case(key, run, sim.reset)


def _mujoco_cases(integrator: str) -> list[Case]:
    mujoco = mjm.mujoco
    m, d = mjm.make(1, INERTIA_BOX, MASS, DT, integrator, site=CORNER_B)
    mj_step = mujoco.mj_step
    ctrl, xfrc = d.ctrl, d.xfrc_applied
    forces = _forces()
    values = (FORCE, -FORCE)

    def setup() -> None:
        mjm.reset(m, d, ANGULAR_VELOCITY)

    def site(k: int) -> None:
        for i in range(k):
            ctrl[0] = values[i & 1]
            mj_step(m, d)

    def world(k: int) -> None:
        for i in range(k):
            xfrc[1, :3] = forces[i & 1]
            mj_step(m, d)

    def bare(k: int) -> None:
        for _ in range(k):
            mj_step(m, d)
    return [Case(("mujoco", integrator, "ctrl + mj_step"), site, setup),
            Case(("mujoco", integrator, "xfrc_applied + mj_step"), world, setup),
            Case(("mujoco", integrator, "mj_step"), bare, setup)]


def per_frame(repeats: int, min_seconds: float, log=print) -> list[dict]:
    """Table (i): per frame and function, the call, apply + step(1) and its excess over step(1), µs."""
    s = scene()
    cases = []
    for function in FUNCTIONS:
        for _label, frame, point in FRAMES:
            cases += _our_cases(Simulator(s, integrator=INTEGRATOR, dt=DT), function, frame, point)
    cases.append(_bare_step(Simulator(s, integrator=INTEGRATOR, dt=DT), ("step(1)",)))
    if mjm.available():
        cases += _mujoco_cases("RK4")
    stats = interleaved(cases, repeats, min_seconds)
    bare = stats[("step(1)",)]
    rows = []
    for function in FUNCTIONS:
        world_call = stats[(function, "world", "call")].median
        world_step = stats[(function, "world", "apply + step(1)")].median
        for label, frame, _point in FRAMES:
            c, w = stats[(function, frame, "call")], stats[(function, frame, "apply + step(1)")]
            rows.append({"function": function, "frame": label, "frame_name": frame, "integrator": INTEGRATOR,
                         **c.scaled(1e6).as_row("call_us"), **w.scaled(1e6).as_row("apply_step_us"),
                         "over_step_us": 1e6 * (w.median - bare.median),
                         "call_vs_world": c.median / world_call, "apply_step_vs_world": w.median / world_step})
    rows.append({"function": "step(1) alone", "frame": "—", "frame_name": "", "integrator": INTEGRATOR,
                 **bare.scaled(1e6).as_row("apply_step_us")})
    if mjm.available():
        for what, match in (("xfrc_applied + mj_step", "<body>/world_aligned"), ("ctrl + mj_step", "site, body axes"),
                            ("mj_step", "—")):
            st = stats[("mujoco", "RK4", what)]
            rows.append({"function": f"MuJoCo {what}", "frame": match, "frame_name": "", "integrator": "RK4",
                         **st.scaled(1e6).as_row("apply_step_us"),
                         "over_step_us": 1e6 * (st.median - stats[("mujoco", "RK4", "mj_step")].median)})
    log("  per-frame apply cost done")
    return rows


def site_force_per_step(repeats: int, min_seconds: float, integrators=tuple(INTEGRATORS), log=print) -> list[dict]:
    """Table (ii): a new site-frame force every step, µs: every integrator of ours, MuJoCo's site actuator beside its match."""
    s = scene()
    cases = []
    for ours in integrators:
        cases.append(_our_cases(Simulator(s, integrator=ours, dt=DT), "apply_force_at_point", "b/corner",
                                (0.0, 0.0, 0.0), tag=(ours,))[1])
        cases.append(_bare_step(Simulator(s, integrator=ours, dt=DT), (ours, "step(1)")))
        if ours in mjm.MATCHED:
            cases.append(_control_case(Simulator(s, integrator=ours, dt=DT), (ours, "control + step(1)")))
    if mjm.available():
        for theirs in mjm.MJ_INTEGRATORS:
            ctrl_case, _world, bare = _mujoco_cases(theirs)
            cases += [ctrl_case, bare]
    stats = interleaved(cases, repeats, min_seconds)
    rows = []
    for ours in integrators:
        mine = stats[(ours, "apply_force_at_point", "b/corner", "apply + step(1)")]
        theirs = mjm.MATCHED.get(ours, "")
        row = {"integrator": ours, "mujoco": theirs, **mine.scaled(1e6).as_row("ours_us"),
               **stats[(ours, "step(1)")].scaled(1e6).as_row("ours_step_only_us")}
        if theirs:
            control = stats[(ours, "control + step(1)")]
            row.update(**control.scaled(1e6).as_row("control_us"))
        if theirs and mjm.available():
            peer = stats[("mujoco", theirs, "ctrl + mj_step")]
            row.update(**peer.scaled(1e6).as_row("mujoco_us"),
                       **stats[("mujoco", theirs, "mj_step")].scaled(1e6).as_row("mujoco_step_only_us"),
                       ratio=mine.median / peer.median, control_ratio=control.median / peer.median)
        rows.append(row)
    log("  site force per step done")
    return rows
