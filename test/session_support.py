"""The simulation session (ros/session.py) with a plain recorder for its edge: the scene, settings
and :func:`make_session` the session tests share."""

from __future__ import annotations

import json
import logging

import numpy as np

from rigid_body_sim.core import Simulator
from rigid_body_sim.core.scene import load_scene_text
from rigid_body_sim.ros.session import SimSession, physics_dt

MASS = 2.0  # kg
X0 = np.array([0.0, 0.0, 1.0])  # m, world
V0 = np.array([0.3, -0.1, 0.0])  # m/s, world
FORCE = np.array([1.0, 2.0, -0.5])  # N, world axes, at the centre of mass
SCENE = {"bodies": {
    "box": {"mass": MASS, "inertia": {"box": [1.0, 0.6, 0.4]},
            "pose": {"position": X0.tolist(), "orientation": [0.0, 0.0, 0.0, 1.0]},
            "twist": {"linear": V0.tolist(), "angular": [0.0, 0.0, 0.0]}},
    "ball": {"mass": 1.0, "inertia": {"sphere": 0.1},
             "pose": {"position": [5.0, 0.0, 0.0], "orientation": [0.0, 0.0, 0.0, 1.0]}},
}}
SETTINGS = {"paused": True, "rate_hz": 100.0, "substeps": 4, "real_time_factor": 1.0, "wrench_timeout": 0.0,
            "publish_odometry": True, "world_frame": "world", "per_body_topics": True, "integrator": "rk4",
            "model_reduction": True}
TICK_S = SETTINGS["real_time_factor"] / SETTINGS["rate_hz"]


class RecordingIO:
    """The session's edge as a list of calls; holds :data:`FORCE` on ``box`` while ``pushing``."""

    def __init__(self) -> None:
        self.calls: list[tuple] = []
        self.pushing = True
        self.set_states: dict[str, np.ndarray] = {}

    def take_set_states(self, sim: Simulator) -> bool:
        pending, self.set_states = self.set_states, {}
        for body, position in pending.items():
            sim.set_body_state(body, position_world=position)
        self.calls.append(("take_set_states", sorted(pending)))
        return bool(pending)

    def take_wrenches(self, sim: Simulator, wrench_timeout: float) -> None:
        if self.pushing:
            sim.apply_wrench("box", force=FORCE)
        self.calls.append(("take_wrenches", sim.time))

    def publish_tick(self, sim, tick_s, settings) -> None:
        self.calls.append(("publish_tick", sim.time, tick_s))

    def publish(self, sim, settings) -> None:
        self.calls.append(("publish", sim.time))

    def publish_bodies(self, sim) -> None:
        self.calls.append(("publish_bodies", sim.body_names))

    def prepare(self, scene, publish_odometry, *, keep_state):
        self.calls.append(("prepare", scene.body_names, keep_state))
        return ("change", scene.body_names, keep_state)

    def commit(self, change) -> None:
        self.calls.append(("commit",) + change[1:])

    def release(self, change) -> None:
        self.calls.append(("release",) + change[1:])

    def replace_recorder(self, recorder):
        return None

    def record_state(self, sim, settings) -> None:
        pass

    def finish_recorder(self, recorder) -> None:
        pass

    def named(self, name: str) -> list[tuple]:
        return [call for call in self.calls if call[0] == name]


def make_session(**kwargs) -> tuple[SimSession, RecordingIO]:
    sim = Simulator(load_scene_text(json.dumps(SCENE), "test scene"), integrator="rk4", dt=physics_dt(SETTINGS))
    io = RecordingIO()
    settings = {**SETTINGS, **kwargs.pop("settings", {})}
    return SimSession(sim, settings, io, logging.getLogger("test_session"), **kwargs), io
