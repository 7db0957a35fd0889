"""docs/choosing_an_integrator.md is true: each of its accuracy claims, re-measured now.

`make bench` writes the page and, beside it, ``choosing_an_integrator.claims.json``: every
accuracy statement of the page in a checkable form, with each problem's definition
(benchmarks/choosing.py). This test re-measures each claim with the public core API against
the closed forms (``closed_form.asymmetric_top``, ``closed_form.box_body_fixed_force``) — never
against the numbers the benchmark wrote — and uses nothing from benchmarks/. Speed figures are
not claims (no wall-clock assertions). The page's order claims are checked in test_order.py,
beside the measurement of every method's order on the same box.

Tolerances: a claim says an error is below (or above) an accuracy goal at a given h; the same
compiled code recomputes it, and only the closed forms' numpy/BLAS paths differ between CPUs
(relative 1e-12 at most), so the goal is compared with a relative slack of 1e-9.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from rigid_body_sim.core import Simulator, load_scene
from rigid_body_sim.exact import closed_form
from rigid_body_sim.core.quaternion import quat_conjugate, quat_multiply

CLAIMS = Path(__file__).resolve().parents[1] / "docs" / "choosing_an_integrator.claims.json"
SLACK = 1e-9


def _data() -> dict:
    return json.loads(CLAIMS.read_text())


def _claims() -> list[dict]:
    return _data()["claims"] if CLAIMS.exists() else []


def _scene(problem: str, spec: dict):
    if problem == "top":
        return load_scene({"bodies": {"b": {"mass": spec["mass_kg"], "inertia": {"principal": spec["principal_inertia_kg_m2"]},
                                            "twist": {"angular": spec["initial_angular_velocity_body_rad_s"]}}}})
    return load_scene({"bodies": {"b": {"mass": spec["mass_kg"], "inertia": {"box": spec["box_sides_m"]},
                                        "sites": {"s": {"position": spec["site_body_m"]}}}}})


def measured_error(problem: str, integrator: str, h: float) -> float:
    """The claim's error measure, fresh: max over the checkpoints (see the claims file's problem definition)."""
    spec = _data()["problems"][problem]
    checkpoints = spec["checkpoints"]
    n = round(spec["horizon_s"] / (checkpoints * h))
    assert n >= 1 and math.isclose(n * checkpoints * h, spec["horizon_s"], rel_tol=1e-9), (problem, h)
    sim = Simulator(_scene(problem, spec), integrator=integrator, dt=h)
    q, p = [], []
    for _ in range(checkpoints):
        if problem == "box":
            sim.apply_force_at_point("b", spec["force_in_site_axes_N"], (0.0, 0.0, 0.0), frame="b/s")
        sim.step(n)
        s = sim.body_state("b")
        x, y, z, w = s.orientation_xyzw
        q.append((w, x, y, z))
        p.append(s.position_world)
    times = np.arange(1, checkpoints + 1) * n * h
    if problem == "top":
        I = np.array(spec["principal_inertia_kg_m2"])
        q_ref, _w = closed_form.asymmetric_top(I, np.array(spec["initial_angular_velocity_body_rad_s"]),
                                               np.array([1.0, 0.0, 0.0, 0.0]), times)
        d = quat_multiply(quat_conjugate(q_ref), np.array(q))
        return float(np.max(2.0 * np.arctan2(np.linalg.norm(d[:, 1:], axis=1), np.abs(d[:, 0]))))
    sides = spec["box_sides_m"]
    I3 = spec["mass_kg"] * (sides[0] ** 2 + sides[1] ** 2) / 12.0
    _q, _w, _v, p_ref = closed_form.box_body_fixed_force(spec["mass_kg"], I3, np.array(spec["force_in_site_axes_N"]),
                                                        np.array(spec["site_body_m"]), times)
    return float(np.max(np.linalg.norm(np.array(p) - p_ref, axis=1)))


def test_the_claims_file_exists_and_names_its_problems():
    assert CLAIMS.exists(), "run `make bench` to generate docs/choosing_an_integrator.md and its claims"
    data = _data()
    assert set(data["problems"]) == {"top", "box"}
    assert data["claims"], "the page makes no accuracy claim"


@pytest.mark.parametrize("claim", [c for c in _claims() if c["kind"] in ("reached", "not_reached")],
                         ids=lambda c: f"{c['problem']}-{c['integrator']}-{c['kind']}-{c.get('max_error', c.get('min_error'))}")
def test_accuracy_goal_claims_hold(claim):
    error = measured_error(claim["problem"], claim["integrator"], claim["h"])
    if claim["kind"] == "reached":
        assert error <= claim["max_error"] * (1 + SLACK), claim
    else:
        assert error > claim["min_error"] * (1 - SLACK), claim
