"""The host side of the compiled step driver (kernels/stepping.py): its parameter rows, and steps without checks.

:func:`pack_parameters` fills the per-body constants the compiled step reads (layout.py names
the columns); :class:`UncheckedStepper` (and :func:`unchecked_steps`) step bodies with one integrator and no
reduction or checks, for measuring integrators themselves.
"""

from __future__ import annotations

import numpy as np

from .free_rotor import rotor_pairing
from .integrators import get_integrator, step_exact_rotor_splitting, step_reference
from .kernels.layout import (
    AXIS_K,
    AXIS_S,
    BUDGET_FORCE,
    BUDGET_TORQUE,
    C_K,
    C_S,
    CACHE_DT,
    CUR,
    DAMP_ANG,
    DAMP_LIN,
    DT,
    GRAVITY,
    GRAVITY_BUDGET_RATE,
    GROUPS,
    INERTIA,
    INV_I_T,
    INV_INERTIA,
    INV_MASS,
    LIMIT,
    MASS,
    MODEL,
    MODEL_FULL,
    PRM_WIDTH,
    PROJECT,
    PROJECT_NONE,
    Q_PB,
    ROW_WIDTH,
    STATE_WIDTH,
    TOP_DT,
    WRENCH_WIDTH,
)
from .kernels.stepping import SCRATCH_ROWS, integrate, new_buffers
from .model import State
from .quaternion import quat_conjugate

__all__ = ["UncheckedStepper", "pack_parameters", "unchecked_steps"]


def pack_parameters(model) -> np.ndarray:
    """The (N, PRM_WIDTH) per-body constants of ``model`` (a BodyModel), every body of model full."""
    n = model.count
    prm = np.zeros((n, PRM_WIDTH))
    inertia = np.asarray(model.inertia_P, dtype=float).reshape(n, 3)
    prm[:, MASS] = model.mass
    prm[:, INV_MASS] = 1.0 / model.mass
    prm[:, INERTIA:INERTIA + 3] = inertia
    prm[:, INV_INERTIA:INV_INERTIA + 3] = 1.0 / inertia
    prm[:, DAMP_LIN] = model.damping_linear
    prm[:, DAMP_ANG] = model.damping_angular
    prm[:, GRAVITY:GRAVITY + 3] = model.gravity_W
    prm[:, BUDGET_FORCE] = 1.0 / np.sqrt(2.0 * model.mass)
    prm[:, BUDGET_TORQUE] = 1.0 / np.sqrt(2.0 * inertia.min(axis=1)) if n else 0.0
    g = np.asarray(model.gravity_W, dtype=float)
    prm[:, GRAVITY_BUDGET_RATE] = model.mass * float(np.hypot(np.hypot(g[0], g[1]), g[2])) * prm[:, BUDGET_FORCE]
    prm[:, MODEL] = MODEL_FULL
    prm[:, PROJECT] = PROJECT_NONE
    prm[:, CACHE_DT] = np.nan
    prm[:, TOP_DT] = np.nan
    prm[:, Q_PB:Q_PB + 4] = quat_conjugate(np.asarray(model.q_BP, dtype=float).reshape(n, 4))
    if n:
        rows = np.arange(n)
        t, s, k = rotor_pairing(inertia)
        I_t, I_s, I_k = inertia[rows, t], inertia[rows, s], inertia[rows, k]
        prm[:, AXIS_S] = s
        prm[:, AXIS_K] = k
        prm[:, INV_I_T] = 1.0 / I_t
        prm[:, C_S] = 1.0 / I_s - 1.0 / I_t
        prm[:, C_K] = 1.0 / I_k - 1.0 / I_t
    return prm



class UncheckedStepper:
    """Steps every body of ``model`` with the integrator ``method_name``, no reduction, no checks.

    For measuring integrators themselves (tools/envelope.py, tests): every body is stepped
    by the integrator (model full, no projection), a non-finite or blown-up result is
    returned as it is, and ``wrenches`` (rows in frame terms, forces.add_wrench; default
    none) hold for every step. The parameter rows and buffers are made once, so a caller
    sampling every step pays for the steps, not for setting them up.
    """

    def __init__(self, method_name: str, model, dt: float, wrenches: np.ndarray | None = None):
        self._method = get_integrator(method_name)
        n = model.count
        self._prm = pack_parameters(model)
        self._Ys, self._status, self._control, inputs = new_buffers(n)
        inputs[DT], inputs[LIMIT] = dt, np.inf
        self._dt = dt
        self._members = np.arange(n, dtype=np.int64)
        self._control[GROUPS + 2 * MODEL_FULL + 1] = n  # every body in the group of model full
        self._rows = np.zeros((n, WRENCH_WIDTH)) if wrenches is None else np.array(wrenches, dtype=float)
        self._scratch = np.empty((SCRATCH_ROWS, ROW_WIDTH))

    def run(self, state, steps: int = 1):
        """``steps`` steps from ``state``; returns a new :class:`~rigid_body_sim.core.model.State`."""
        return State.of_rows(self.samples(state, [steps])[-1])

    def samples(self, state, counts) -> np.ndarray:
        """From ``state``, ``counts[0]`` steps, then ``counts[1]`` more, ...: the (len(counts), N, 13) state rows
        (p, q, v, w; layout.py) after each count, a new array."""
        Ys, control, method, dt = self._Ys, self._control, self._method, self._dt
        prm, rows, members = self._prm, self._rows, self._members
        if method.code is None:  # the numpy-stepped methods
            host = step_exact_rotor_splitting if method.name == "exact_rotor_splitting" else step_reference

            def step(y0: np.ndarray, y1: np.ndarray) -> None:
                host(y0, y1, prm, rows, members, dt)
        else:
            def step(y0: np.ndarray, y1: np.ndarray) -> None:
                integrate(method.code, y0, y1, prm, rows, members, self._status, dt, np.inf, self._scratch)
        out = np.empty((len(counts), len(members), STATE_WIDTH))
        Ys[control[CUR], :, :STATE_WIDTH] = state.rows()
        with np.errstate(all="ignore"):
            for k, steps in enumerate(counts):
                for _ in range(steps):
                    cur = control[CUR]
                    step(Ys[cur], Ys[1 - cur])
                    control[CUR] = 1 - cur
                out[k] = Ys[control[CUR], :, :STATE_WIDTH]
        return out


def unchecked_steps(method_name: str, model, state, dt: float, steps: int = 1, wrenches: np.ndarray | None = None):
    """``steps`` steps of every body of ``model`` with the integrator ``method_name``, no reduction, no checks
    (:class:`UncheckedStepper`). Returns a new :class:`~rigid_body_sim.core.model.State`."""
    return UncheckedStepper(method_name, model, dt, wrenches).run(state, steps)
