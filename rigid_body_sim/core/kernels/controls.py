"""The control array: wrenches a controller writes straight into numpy rows, checked and added inside the step.

MuJoCo's idiom (``d.ctrl[0] = f; mj_step(m, d)``): a controller writes numbers into an array
the simulator owns, and the compiled step reads them; no call per input. The controls are one
float64 array ``table`` of shape (C + 1, CONTROL_WIDTH): row k < C is one control,

=========  ================================================================================
columns    meaning
=========  ================================================================================
0–2        force (N), in the control frame's axes (the frame rule of forces.py)
3–5        torque (N·m) about the frame's origin, in its axes
6–10       the head: body index, layout.FRAME_* kind, the site's arm in principal axes (m)
11         1 if the last step call rejected the row, else 0
=========  ================================================================================

and the last row holds the number of rows in use in column 0. Simulator.control hands out
``table[k, 0:6]`` as a view; the step adds rows 0..count−1.

A row is checked before anything of it is added: its six numbers and the wrench they make in
frame terms (a force at a site far out can overflow its moment) must be finite. A row that is
not is skipped whole (nothing of it acts on its body; the other rows act) and marked.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .forces import add_wrench
from .jit import JIT
from .layout import ACTIVE, ROW_WIDTH, WRENCH_WIDTH
from .stepping import SCRATCH_ROWS, add_pending, advance_in

__all__ = ["add_controls", "add_controls_in", "advance_controlled", "advance_controlled_in", "CONTROL_WIDTH", "VALUES", "HEAD", "REJECTED", "new_table"]

#: Columns of a control row: the six values, then the head, then the rejected flag.
VALUES, HEAD, REJECTED, CONTROL_WIDTH = 0, 6, 11, 12


def new_table(capacity: int) -> np.ndarray:
    """An empty control table of ``capacity`` rows (plus the count row)."""
    return np.zeros((capacity + 1, CONTROL_WIDTH))


@njit(**JIT)
def add_controls(wrenches, prm, table):
    """Add the table's rows in use to their bodies' wrench rows; returns how many were rejected (and marks them)."""
    return add_controls_in(wrenches, prm, table, np.empty(WRENCH_WIDTH))


@njit(**JIT)
def add_controls_in(wrenches, prm, table, scratch):
    """:func:`add_controls` with its scratch given: ``scratch`` (WRENCH_WIDTH,) float64, contents irrelevant."""
    count = int(table[table.shape[0] - 1, 0])
    bad = 0
    for k in range(count):
        row = table[k]
        fx, fy, fz, tx, ty, tz = row[0], row[1], row[2], row[3], row[4], row[5]
        ok = (fx * 0.0 + fy * 0.0) + (fz * 0.0 + tx * 0.0) + (ty * 0.0 + tz * 0.0) == 0.0  # NaN for inf or NaN
        b = int(row[HEAD])
        if ok:
            scratch[:] = 0.0
            add_wrench(scratch, prm[b], int(row[HEAD + 1]), row[HEAD + 2], row[HEAD + 3], row[HEAD + 4],
                       fx, fy, fz, tx, ty, tz)
            total = 0.0
            for j in range(ACTIVE):
                total += scratch[j] * 0.0
            ok = total == 0.0
        if ok:
            w = wrenches[b]
            for j in range(ACTIVE):
                w[j] += scratch[j]
            w[ACTIVE] = 1.0
            row[REJECTED] = 0.0
        else:
            row[REJECTED] = 1.0
            bad += 1
    return bad


@njit(**JIT)
def advance_controlled(Ys, prm, wrenches, members, status, control, inputs, n_steps, cancel, table):
    """stepping.advance with the control rows added first (after the pending wrench).

    The controls join the wrench rows as an applied wrench does: held for the call's steps,
    then spent with them. Returns the steps done, or −1 − the steps done when a row was
    rejected (one integer, so that a step with controls costs Python one comparison more).
    """
    return advance_controlled_in(Ys, prm, wrenches, members, status, control, inputs, n_steps, cancel, table,
                                 np.empty((SCRATCH_ROWS, ROW_WIDTH)), np.empty(members.shape[0], dtype=np.int64),
                                 np.empty(WRENCH_WIDTH))


@njit(**JIT)
def advance_controlled_in(Ys, prm, wrenches, members, status, control, inputs, n_steps, cancel, table, k, deferred,
                          scratch):
    """:func:`advance_controlled` with its scratch given (stepping.advance_in's ``k`` and ``deferred``, and
    :func:`add_controls_in`'s ``scratch``)."""
    add_pending(wrenches, prm, inputs)
    bad = add_controls_in(wrenches, prm, table, scratch)
    done = advance_in(Ys, prm, wrenches, members, status, control, inputs, n_steps, cancel, k, deferred)
    if bad:
        done = -1 - done
    return done
