"""Model reduction: per body, the cheapest model that is exact for what the scene declares and what the body is.

A scene compiler over a :class:`~rigid_body_sim.core.model.BodyModel` and its current state.
Each body gets one of the models of layout.py (MODEL_*) and the wrench projection its
declared motion allows (L.PROJECT_*); the moving bodies are listed grouped by model, so
each kernel pass runs over a homogeneous group and static bodies are never touched.

=====================  ==========================================================================
model                  when, and what the step does
=====================  ==========================================================================
static                 ``motion: static`` (or a body stopped by Simulator.stop_body): nothing
kinematic              ``motion: kinematic``: p += v dt, q ← exp(ω_W dt) ⊗ q; deaf to wrenches
planar                 ``motion: planar``: exact flow of x, y, yaw under the step's wrench
                       (force in the plane, torque along its normal; the rest projected out)
translation            ``motion: translation_only``: exact constant-force flow; q fixed
isotropic              I1 = I2 = I3 (free or rotation_only): no gyroscopic term; exact
                       translation and exact exp-map rotation while torque-free
symmetric              two equal moments and no angular damping (free or rotation_only): exact
                       translation and the exact symmetric-top flow while torque-free
full                   everything else: the integrator (also isotropic/symmetric bodies in a
                       step where a torque acts on them: re-derived every step)
=====================  ==========================================================================

What it gains (benchmarks/reduction.py times every model against every integrator it replaces):
a static body costs nothing; the translation model is exact and several times cheaper than any
integrator's step; the isotropic and symmetric models are exact (round-off only) and cheaper
than every integrator's step but ``euler``'s, which costs about as much. Under ``euler`` they
are kept for their exactness: a ball's parabola through its impacts, a box at rest on a face
that stays exactly there (the contact tests rely on both).

``rotation_only`` bodies keep the centre of mass put by projection (no force, no gravity, zero
velocity); ``translation_only`` bodies keep their orientation. With ``reduce=False`` (the
switch) only the declared constraints keep their exact models (kinematic, planar: they are
not motions the full equations can make); static and translation-only bodies, isotropic and
symmetric ones are all stepped by the integrator, with the same projections.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .kernels import layout as L
from .free_rotor import EQUAL_MOMENTS_RTOL
from .model import BodyModel, State
from .quaternion import quat_rotate, quat_to_matrix

__all__ = ["BodyPlan", "MODEL_NAMES", "model_codes", "plan_models", "apply_plan"]

#: L.MODEL_* → the name used in describe output and logs.
MODEL_NAMES = {
    L.MODEL_FULL: "full",
    L.MODEL_STATIC: "static",
    L.MODEL_KINEMATIC: "kinematic",
    L.MODEL_TRANSLATION: "translation",
    L.MODEL_PLANAR: "planar",
    L.MODEL_ISOTROPIC: "isotropic",
    L.MODEL_SYMMETRIC: "symmetric",
}

_PROJECTION = {
    "free": L.PROJECT_NONE,
    "static": L.PROJECT_ALL,
    "kinematic": L.PROJECT_ALL,
    "planar": L.PROJECT_PLANE,
    "rotation_only": L.PROJECT_FORCE,
    "translation_only": L.PROJECT_TORQUE,
}


@dataclass(frozen=True)
class BodyPlan:
    """The model one body gets. ``model`` is a key of MODEL_NAMES' values; ``reason`` says why."""

    body: str
    motion: str
    model: str
    code: int
    reason: str


def model_codes(model: BodyModel, reduce: bool = True, stopped: np.ndarray | None = None) -> np.ndarray:
    """The model (layout.MODEL_*) each body of ``model`` gets, shape (N,) int64: arrays only, no per-body Python.

    What :func:`plan_models` explains; this is what the simulator re-derives whenever a body is
    stopped, set or reset, so it must stay cheap at 1e5 bodies.
    """
    inertia = np.asarray(model.inertia_P, dtype=float).reshape(-1, 3)
    motions = np.asarray(model.motions, dtype=object)

    def equal(a: np.ndarray, b: np.ndarray) -> np.ndarray:
        return np.abs(a - b) <= EQUAL_MOMENTS_RTOL * np.maximum(np.abs(a), np.abs(b))

    I1, I2, I3 = inertia[:, 0], inertia[:, 1], inertia[:, 2]
    isotropic = equal(I1, I2) & equal(I2, I3)
    pair = equal(I1, I2) | equal(I2, I3) | equal(I1, I3)
    symmetric = pair & (np.asarray(model.damping_angular) == 0.0)
    free_to_turn = (motions == "free") | (motions == "rotation_only")
    codes = np.full(model.count, L.MODEL_FULL, dtype=np.int64)
    if reduce:
        codes[free_to_turn & symmetric] = L.MODEL_SYMMETRIC
        codes[free_to_turn & isotropic] = L.MODEL_ISOTROPIC
        codes[motions == "translation_only"] = L.MODEL_TRANSLATION
        codes[motions == "static"] = L.MODEL_STATIC
    codes[motions == "planar"] = L.MODEL_PLANAR
    codes[motions == "kinematic"] = L.MODEL_KINEMATIC
    if stopped is not None:
        codes[np.asarray(stopped, dtype=bool)] = L.MODEL_STATIC
    return codes


def plan_models(model: BodyModel, reduce: bool = True, stopped: np.ndarray | None = None,
                codes: np.ndarray | None = None, first: int | None = None) -> list[BodyPlan]:
    """Which model each body of ``model`` gets, and why (one :class:`BodyPlan` per body, in order).

    ``codes`` are :func:`model_codes`' (computed here when not given); this adds the reasons.
    ``first``: only the first that many bodies (default all).
    """
    if codes is None:
        codes = model_codes(model, reduce, stopped)
    plans = []
    motions = model.motions
    normals = model.plane_normals_W
    for b, name in enumerate(model.names[:first]):
        motion, code = motions[b], int(codes[b])
        I = model.inertia_P[b]
        moments = f"I = ({I[0]:.6g}, {I[1]:.6g}, {I[2]:.6g}) kg·m²"
        if stopped is not None and stopped[b]:
            reason = "stopped by Simulator.stop_body: no longer integrated"
        elif code == L.MODEL_STATIC:
            reason = "motion: static: never integrated"
        elif code == L.MODEL_KINEMATIC:
            reason = "motion: kinematic: moves at its constant initial twist (exact), deaf to wrenches"
        elif code == L.MODEL_PLANAR:
            n = normals[b]
            reason = (f"motion: planar (normal [{n[0]:.6g}, {n[1]:.6g}, {n[2]:.6g}]): in-plane position and yaw, "
                      "exact under an in-plane wrench fixed in world axes, RK4 on the planar equations under one "
                      "that turns or moves with the body; force out of the plane and tilting torque projected out")
        elif code == L.MODEL_TRANSLATION:
            reason = ("motion: translation_only: exact flow of the centre of mass under its forces; orientation "
                      "fixed, torques projected out")
        elif code == L.MODEL_ISOTROPIC:
            reason = (f"isotropic inertia ({moments}): no gyroscopic term; exact translation and exact exp-map "
                      "rotation while no torque acts and the force is fixed in world axes, the integrator otherwise")
        elif code == L.MODEL_SYMMETRIC:
            reason = (f"axisymmetric inertia ({moments}), no angular damping: exact translation and exact "
                      "symmetric-top flow while no torque acts and the force is fixed in world axes, the "
                      "integrator otherwise")
        elif motion == "static":
            reason = "motion: static, stepped by the integrator with every wrench projected out (reduction off)"
        elif motion == "translation_only":
            reason = "motion: translation_only, stepped by the integrator with torques projected out (reduction off)"
        else:
            pair = any(abs(I[i] - I[j]) <= EQUAL_MOMENTS_RTOL * max(abs(I[i]), abs(I[j]))
                       for i, j in ((0, 1), (1, 2), (0, 2)))
            why = "reduction off" if not reduce else (
                "asymmetric inertia" if not pair else "axisymmetric but with angular damping")
            reason = f"the integrator ({why}, {moments})"
        if motion == "rotation_only":
            reason += "; motion: rotation_only: the centre of mass stays put (forces and gravity projected out)"
        plans.append(BodyPlan(name, motion, MODEL_NAMES[code], code, reason))
    return plans


def apply_plan(prm: np.ndarray, model: BodyModel, initial: State, state: State, codes: np.ndarray
               ) -> tuple[np.ndarray, np.ndarray]:
    """Write the models ``codes`` (:func:`model_codes`) into the parameter rows ``prm`` (in place); return the
    moving bodies grouped by model.

    Per body: MODEL, PROJECT, the projected gravity (and its energy-bound rate), and for planar
    bodies the plane (normal, offset n·p of the ``initial`` position: the plane the scene put
    it in) and the moment about its normal nᵀ R I Rᵀ n at ``state`` (constant under yaw), for
    kinematic bodies the world angular velocity of ``state``.

    Returns
    -------
    members : ndarray of int64, shape (M,)
        Every non-static body, sorted by model code (stable within a model).
    groups : ndarray of int64, shape (MODEL_COUNT, 2)
        [start, end) in ``members`` of each model's bodies (stepping.py, control[GROUPS]).
    """
    gravity = np.asarray(model.gravity_W, dtype=float)
    normals = model.plane_normals_W
    motions = model.motions
    prm[:, L.MODEL] = codes
    prm[:, L.PROJECT] = [_PROJECTION[m] for m in motions]
    g = np.tile(gravity, (model.count, 1))
    g[[m in ("static", "kinematic", "rotation_only") for m in motions]] = 0.0
    for b in np.flatnonzero([m == "planar" for m in motions]):
        n = normals[b]
        g[b] -= (g[b] @ n) * n
        prm[b, L.NORMAL:L.NORMAL + 3] = n
        prm[b, L.PLANE_OFFSET] = float(initial.p_WC_W[b] @ n)
        R = quat_to_matrix(state.q_WP[b])
        prm[b, L.INERTIA_NORMAL] = float(n @ (R @ (model.inertia_P[b] * (R.T @ n))))
    for b in np.flatnonzero([m == "kinematic" for m in motions]):
        prm[b, L.KINEMATIC_W:L.KINEMATIC_W + 3] = quat_rotate(state.q_WP[b], state.w_WP_P[b])
    prm[:, L.GRAVITY:L.GRAVITY + 3] = g
    prm[:, L.CACHE_DT] = np.nan  # no cached rotation increment
    prm[:, L.TOP_DT] = np.nan  # nor symmetric-top increments
    # |m g| as m |g| with a hypot-style norm: no sum of squares to overflow
    prm[:, L.GRAVITY_BUDGET_RATE] = model.mass * np.hypot(np.hypot(g[:, 0], g[:, 1]), g[:, 2]) * prm[:, L.BUDGET_FORCE]
    moving = np.flatnonzero(codes != L.MODEL_STATIC)
    members = moving[np.argsort(codes[moving], kind="stable")].astype(np.int64)
    counts = np.bincount(codes[members], minlength=L.MODEL_COUNT)
    ends = np.cumsum(counts)
    groups = np.stack((ends - counts, ends), axis=1).astype(np.int64)
    return members, groups
