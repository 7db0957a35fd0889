"""Compile (or load from numba's cache) every compiled entry point, with the argument types the core passes.

``make venv`` and the node's first start call :func:`compile_kernels`, so that neither the
first step nor the first test pays for compiling. It calls each function that Python calls
(the others are compiled into them) once on one body's buffers built as the Simulator builds
them, so each gets the exact signature it is later called with; test_kernel_cache.py checks
that stepping a Simulator with every integrator adds no signature afterwards.
"""

from __future__ import annotations

import numpy as np

from . import layout as L
from .controls import add_controls, advance_controlled, new_table
from .dynamics import derivatives, impulse_response
from .forces import add_wrench, project_twist
from .integrators import INTEGRATORS, final_kick, kick_and_drift
from .sensors import site_readings
from .state_rows import pose_twist_rows
from .stepping import SCRATCH_ROWS, add_pending, advance, check_members, clear_wrenches, integrate, new_buffers, \
    step_reduced

__all__ = ["compile_kernels", "ENTRY_POINTS"]

#: The compiled functions called from Python (core/simulator.py, core/stepping.py, core/integrators.py).
ENTRY_POINTS = (advance, advance_controlled, add_controls, step_reduced, check_members, add_pending, clear_wrenches, integrate, kick_and_drift,
                final_kick, derivatives, impulse_response, add_wrench, project_twist, site_readings, pose_twist_rows)


def compile_kernels() -> None:
    """Compile or load every function of :data:`ENTRY_POINTS`: about two CPU-minutes once per change of kernels/."""
    n = 1
    Ys, status, control, inputs = new_buffers(n)
    prm = np.zeros((n, L.PRM_WIDTH))
    prm[:, L.MASS] = prm[:, L.INV_MASS] = 1.0
    prm[:, L.INERTIA:L.INERTIA + 3] = prm[:, L.INV_INERTIA:L.INV_INERTIA + 3] = 1.0
    Ys[:, :, L.Q] = 1.0
    wrenches = np.zeros((n, L.WRENCH_WIDTH))
    members = np.arange(n, dtype=np.int64)
    control[L.GROUPS + 2 * L.MODEL_FULL + 1] = n
    inputs[L.DT] = 0.01
    inputs[L.LIMIT] = np.inf
    for method in INTEGRATORS.values():
        if method.code is not None:
            control[L.METHOD] = method.code
            advance(Ys, prm, wrenches, members, status, control, inputs, 1, np.zeros(1, dtype=np.int64))
            integrate(method.code, Ys[0], Ys[1], prm, wrenches, members, status, 0.01, np.inf,
                      np.empty((SCRATCH_ROWS, L.ROW_WIDTH)))
    table = new_table(1)
    table[1, 0] = 1
    advance_controlled(Ys, prm, wrenches, members, status, control, inputs, 1, np.zeros(1, dtype=np.int64), table)
    add_controls(wrenches, prm, table)
    bodies = step_reduced(Ys, prm, wrenches, members, status, control, inputs)
    kick_and_drift(Ys[0], Ys[1], prm, wrenches, bodies, 0.01)
    final_kick(Ys[1], prm, wrenches, bodies, 0.01)
    check_members(Ys, prm, wrenches, members, status, control, inputs)
    add_pending(wrenches, prm, inputs)
    clear_wrenches(wrenches)
    derivatives(Ys[0][:, :L.STATE_WIDTH].copy(), prm, wrenches, np.empty((n, L.STATE_WIDTH)))
    row = np.zeros(L.WRENCH_WIDTH)
    add_wrench(row, prm[0], L.FRAME_BODY, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    impulse_response(Ys[0][0], prm[0], row, np.empty(L.ROW_WIDTH))
    project_twist(prm[0], np.zeros(6))
    pose_twist_rows(Ys[0], np.array([[1.0, 0.0, 0.0, 0.0]]), np.empty((n, 7)), np.zeros((n, 7)), np.empty(n, dtype=np.bool_))
    site_readings(Ys[0], prm, wrenches, np.zeros(3), np.zeros(1, dtype=np.int64), np.zeros((1, 3)),
                  np.zeros(1, dtype=np.bool_), np.empty((1, 10)))
    # A cfunc is compiled (or loaded) where it is defined: imported here, under the caller's cache lock.
    from . import single_step

    block, sizes = single_step.new_block()
    for rows in (None, table):
        single_step.fill_block(block, sizes, Ys, prm, wrenches, members, status, control, inputs,
                               np.zeros(1, dtype=np.int64), rows, np.empty((SCRATCH_ROWS, L.ROW_WIDTH)),
                               np.empty(n, dtype=np.int64), np.empty(L.WRENCH_WIDTH))
        single_step.entry()(block.ctypes.data)
