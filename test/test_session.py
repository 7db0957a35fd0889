"""The simulation session (ros/session.py) driven directly: no node, no DDS.

The session's edge is a plain recorder (:class:`RecordingIO`) that holds one constant world-frame
force on the body it is given. Physics is checked against the closed form of a free body under a
constant force at its centre of mass, x(t) = x0 + v0 t + F t² / (2 m): rk4 integrates a quadratic
in time exactly, so the only error is rounding (tolerance: a few ulps of the largest term times
the number of steps).
"""

from __future__ import annotations

import json
import logging
import subprocess
import sys
import threading
import time

import numpy as np
import pytest

from rigid_body_sim.core import Simulator
from rigid_body_sim.core.scene import load_scene_text
from rigid_body_sim.ros.session import MAX_STEP_TICKS, SimSession, physics_dt

from session_support import FORCE, MASS, SCENE, SETTINGS, TICK_S, V0, X0, RecordingIO, make_session


def closed_form(t: float) -> tuple[np.ndarray, np.ndarray]:
    """Position (m) and velocity (m/s) of the box's centre of mass after t seconds under FORCE."""
    return X0 + V0 * t + FORCE * t**2 / (2 * MASS), V0 + FORCE * t / MASS


def assert_box_follows_closed_form(session: SimSession, steps: int) -> None:
    state = session.simulator.body_state("box")
    position, velocity = closed_form(session.simulator.time)
    ulps = steps * 8 * np.finfo(float).eps
    np.testing.assert_allclose(state.position_world, position, rtol=0, atol=ulps * np.abs(position).max())
    np.testing.assert_allclose(state.linear_velocity_world, velocity, rtol=0, atol=ulps * np.abs(velocity).max())


def test_session_imports_no_ros():
    """session.py runs without rclpy or any message package (a fresh interpreter's modules)."""
    code = ("import sys, rigid_body_sim.ros.session\n"
            "print([m for m in sys.modules if m.split('.')[0] == 'rclpy' or m.split('.')[0].endswith('_msgs')"
            " or m.split('.')[0].endswith('_interfaces')])")
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, check=True)
    assert result.stdout.strip() == "[]", result.stdout


def test_ticks_follow_the_closed_form_of_a_constant_force():
    session, io = make_session(settings={"paused": False})
    with session.lock:
        for _ in range(25):
            session.tick()
    assert session.simulator.step_count == 25 * SETTINGS["substeps"]
    assert session.simulator.time == pytest.approx(25 * TICK_S, abs=1e-12)
    assert_box_follows_closed_form(session, 100)
    # Per tick: set_states first, then the wrenches, then publishing after the steps.
    assert [call[0] for call in io.calls[:3]] == ["take_set_states", "take_wrenches", "publish_tick"]
    assert io.named("publish_tick")[-1][1:] == (pytest.approx(25 * TICK_S, abs=1e-12), TICK_S)


def test_a_paused_tick_does_not_step_but_shows_a_set_state():
    session, io = make_session()
    with session.lock:
        session.tick()
    assert session.simulator.time == 0.0 and not io.named("publish")
    io.set_states["ball"] = np.array([1.0, 2.0, 3.0])
    with session.lock:
        session.tick()
    assert session.simulator.time == 0.0
    np.testing.assert_array_equal(session.simulator.body_state("ball").position_world, [1.0, 2.0, 3.0])
    assert io.named("publish") == [("publish", 0.0)]


def test_step_while_paused_and_step_ticks():
    session, io = make_session()
    assert session.step_paused() == (True, f"stepped one tick to t = {TICK_S:.9f} s")
    ok, message = session.step_ticks(9)
    assert ok and message == f"stepped 9 ticks to t = {10 * TICK_S:.9f} s"
    assert len(io.named("publish_tick")) == 10
    assert_box_follows_closed_form(session, 40)
    for bad in (0, -1, MAX_STEP_TICKS + 1):
        ok, message = session.step_ticks(bad)
        assert not ok and f"expected an integer from 1 to {MAX_STEP_TICKS}" in message
    assert session.simulator.time == pytest.approx(10 * TICK_S, abs=1e-12)


def test_step_is_refused_while_running():
    session, _ = make_session(settings={"paused": False})
    for ok, message in (session.step_paused(), session.step_ticks(3)):
        assert not ok and "running; pause it first" in message
    assert session.simulator.time == 0.0


def test_reset_goes_back_to_t0_and_starts_the_edge_afresh():
    restarts = []
    session, io = make_session(on_restart=lambda: restarts.append(session.simulator.time))
    assert session.step_ticks(7)[0]
    io.calls.clear()
    ok, message = session.reset()
    assert ok and "t = 0 s" in message
    assert session.simulator.time == 0.0 and session.simulator.step_count == 0
    state = session.simulator.body_state("box")
    np.testing.assert_array_equal(state.position_world, X0)
    np.testing.assert_array_equal(state.linear_velocity_world, V0)
    assert restarts == [0.0]
    names = session.simulator.body_names
    assert io.calls == [("prepare", names, False), ("commit", names, False), ("publish", 0.0)]
    assert session.step_ticks(5)[0]  # the same closed form again from t = 0
    assert_box_follows_closed_form(session, 20)


def test_a_fault_refuses_ticks_until_reset_unless_the_tick_thread_died():
    session, _ = make_session(max_time_s=3.5 * TICK_S)
    assert session.step_ticks(3)[0]
    ok, message = session.step_ticks(2)
    assert not ok and message.startswith("stopped after 0 of 2 ticks") and "end of ROS time" in message
    assert session.fault is not None and session.simulator.time == pytest.approx(3 * TICK_S, abs=1e-12)
    assert not session.step_paused()[0]
    assert session.reset()[0] and session.fault is None
    assert session.step_paused()[0]
    session.fail("tick thread failed: RuntimeError('x'); no more ticks")
    assert session.reset()[0]
    ok, message = session.step_paused()
    assert not ok and message == "refused: tick thread failed: RuntimeError('x'); no more ticks"


def test_spawn_and_delete_keep_time_and_the_other_bodies():
    renamed = []
    session, io = make_session(on_bodies=renamed.append)
    assert session.step_ticks(5)[0]
    t, box = session.simulator.time, session.simulator.body_state("box")
    ok, message = session.edit({"crate": json.dumps({"mass": 3.0, "inertia": {"sphere": 0.2}})}, [])
    assert ok and message == f"spawned ['crate'] at t = {t:.9f} s"
    assert session.simulator.body_names == ("box", "ball", "crate") and session.simulator.time == t
    np.testing.assert_array_equal(session.simulator.body_state("box").position_world, box.position_world)
    assert ("prepare", ("box", "ball", "crate"), True) in io.calls  # kept bodies keep holds and IMU state
    assert io.named("publish_bodies")[-1] == ("publish_bodies", ("box", "ball", "crate"))
    assert renamed == [("box", "ball", "crate")]

    ok, message = session.edit({}, ["ball"])
    assert ok and message == f"deleted ['ball'] at t = {t:.9f} s"
    assert session.simulator.body_names == ("box", "crate") and renamed[-1] == ("box", "crate")
    assert session.step_ticks(5)[0]  # the box goes on under the same closed form
    assert_box_follows_closed_form(session, 40)


def test_a_refused_edit_changes_nothing():
    session, io = make_session(settings={"world_frame": "map"})
    for spawn, delete, expected in (({}, ["nobody"], "cannot delete ['nobody']: no such body"),
                                    ({"box": "{mass: 1.0}"}, [], "a body of that name exists"),
                                    ({"c": "[1, 2]"}, [], "expected a mapping"),
                                    ({}, ["box", "ball"], "would leave no body"),
                                    ({"map": json.dumps({"mass": 1.0, "inertia": {"sphere": 0.1}})}, [],
                                     "clashes with world_frame")):
        ok, message = session.edit(spawn, delete)
        assert not ok and message.startswith("refused: ") and expected in message
    assert session.simulator.body_names == ("box", "ball") and not io.named("prepare")


def test_a_spawn_into_another_body_where_it_is_now_is_refused_and_changes_nothing():
    """The box (1.0 × 0.6 × 0.4 m, not turning, not pushed) moves +x from x = 0; a ball of radius 0.1 spawned
    0.55 m beyond its +x face's centre line overlaps it by 0.5 + 0.1 − 0.55 = 0.05 m where the box
    is now; the same ball at the box's start, which it has left, is accepted."""
    scene = {**SCENE, "ground": [{"normal": [0.0, 0.0, 1.0], "offset": -1.0}]}
    sim = Simulator(load_scene_text(json.dumps(scene), "test scene"), integrator="rk4", dt=physics_dt(SETTINGS))
    io = RecordingIO()
    io.pushing = False
    session = SimSession(sim, dict(SETTINGS), io, logging.getLogger("test_session"))
    assert session.step_ticks(50)[0]
    box_now = session.simulator.body_state("box").position_world
    assert box_now[0] - X0[0] > 0.1  # it has moved on at V0
    before = session.simulator.state.copy()
    ball = {"mass": 1.0, "inertia": {"sphere": 0.1}}
    ok, message = session.edit({"pea": json.dumps({**ball, "pose": {"position": (box_now + [0.55, 0, 0]).tolist()}})}, [])
    assert not ok and message.startswith("refused: spawn/delete request: bodies.pea: its collision shape would "
                                         "overlap box's by ")
    depth = float(message.split("overlap box's by ")[1].split(" m")[0])
    assert depth == pytest.approx(0.05, abs=1e-12)
    assert session.simulator.body_names == ("box", "ball") and not io.named("prepare")
    np.testing.assert_array_equal(session.simulator.state.rows(), before.rows())
    ok, message = session.edit({"pea": json.dumps({**ball, "pose": {"position": (X0 - [0.55, 0, 0]).tolist()}})}, [])
    assert ok, message
    assert session.simulator.body_names == ("box", "ball", "pea")


class BackToBackTicks:
    """A tick thread whose ticks overrun their period: each holds the lock ``tick_s`` and the next
    one starts at once (through ``session.lock.ticks``, as tick_loop.py takes it)."""

    def __init__(self, session: SimSession, tick_s: float):
        self.started = 0  # ticks started so far
        self._session, self._tick_s = session, tick_s
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run)

    def _run(self) -> None:
        while not self._stop.is_set():
            with self._session.lock.ticks:
                self.started += 1
                time.sleep(self._tick_s)  # a step that keeps the lock (the GIL is free, as in a compiled step)

    def __enter__(self) -> "BackToBackTicks":
        self._thread.start()
        while not self.started:
            time.sleep(0.001)
        return self

    def __exit__(self, *exc) -> None:
        self._stop.set()
        self._thread.join()


def test_requests_get_in_between_back_to_back_ticks():
    """Each request waits for the tick under way at most, never for the one after it: the lock
    lets every caller already waiting in before the next tick."""
    session, io = make_session(settings={"paused": False}, busy_wait_s=1.0)
    seen = []  # ticks started when a request arrived, and when it got the lock
    io.take_set_states = lambda sim: False  # the fake ticks never call it; requests do not either
    with BackToBackTicks(session, tick_s=0.05) as ticks:
        original_prepare = io.prepare

        def prepare(*args, **kwargs):
            seen[-1].append(ticks.started)
            return original_prepare(*args, **kwargs)

        io.prepare = prepare
        for _ in range(10):
            seen.append([ticks.started])
            ok, message = session.reset()
            assert ok, message
            time.sleep(0.013)  # arrive at different moments of the ticks
    assert all(got - arrived <= 1 for arrived, got in seen), seen


def test_busy_refusal_says_who_holds_the_simulator_and_for_how_long():
    """A refusal names what kept the simulator (a tick, or another request) and how long it has
    been running, measured, not guessed: at least the wait, at most the time since it started."""
    session, _ = make_session(busy_wait_s=0.2)
    with BackToBackTicks(session, tick_s=3.0):
        start = time.monotonic()
        answers = [session.step_paused(), session.step_ticks(2), session.reset(), session.edit({}, ["ball"])]
        assert session.tick_running_for() == pytest.approx(time.monotonic() - start, abs=0.1)
        elapsed = time.monotonic() - start
    assert elapsed < 2.0  # each waited busy_wait_s, not for the tick
    for ok, message in answers:
        assert not ok and message.startswith("refused: busy: a tick has been running for "), message
        assert "heavy scene" in message
    running = [float(message.split("running for ")[1].split(" s")[0]) for _, message in answers]
    assert running == sorted(running) and 0.2 - 0.05 <= running[0] and running[-1] <= elapsed + 0.05, running
    assert session.simulator.time == 0.0 and session.simulator.body_names == ("box", "ball")
    assert session.tick_running_for() is None and session.step_paused()[0]  # no tick: served again

    holding, release = threading.Event(), threading.Event()

    def long_request() -> None:
        with session.lock("~/step_ticks"):
            holding.set()
            release.wait(10)

    thread = threading.Thread(target=long_request)
    thread.start()
    try:
        assert holding.wait(10)
        ok, message = session.reset()
        assert not ok and message.startswith("refused: busy: ~/step_ticks has been running for ") and "heavy" not in message
        assert 0.15 <= float(message.split("running for ")[1].split(" s")[0]) < 10.0, message
        assert session.tick_running_for() is None  # a request, not a tick, holds it
    finally:
        release.set()
        thread.join()


def test_a_settings_change_applies_whole():
    session, io = make_session()
    error, change = session.begin_change({"substeps": 10, "integrator": "semi_implicit_euler"},
                                         open_recorder=lambda *a: None)
    assert error is None and session.change_lock.locked()  # held from prepare to apply
    assert session.simulator.dt == physics_dt(SETTINGS)  # prepared, not applied
    changed = session.apply_change(change)
    assert changed == {"substeps", "integrator"} and not session.change_lock.locked()
    assert session.simulator.dt == pytest.approx(TICK_S / 10)
    assert session.simulator.integrator == "semi_implicit_euler"
    assert session.settings["substeps"] == 10 and not io.named("prepare")  # no endpoint changes
    error, change = session.begin_change({"scene": "/nonexistent/scene.yaml"}, open_recorder=lambda *a: None)
    assert change is None and error.startswith("scene rejected: ") and not session.change_lock.locked()
