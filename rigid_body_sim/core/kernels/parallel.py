"""The compiled step over the bodies on several threads (numba ``prange``), equal to the bit for any thread count.

:func:`advance_parallel` does what stepping.advance does, with the bodies of each step split
into fixed parts (:func:`parts_of`: each a run of one model's group, at most ``PART_BODIES``
long, the same whatever the thread count) that run on numba's threads. A body's step reads
only its own rows and writes only its own rows and status (stepping.step_group), so which
thread runs a part, and how many there are, cannot change a bit of it; the one value that
combines bodies, the worst outcome of the step, is taken per part and then over the parts in
their order. The cancel flag is read between steps, as in stepping.advance.

Threads: :func:`run_parallel` sets numba's thread count for the call (``numba.set_num_threads``,
which is per calling thread) and holds one process-wide lock while the kernel runs, so two
simulators stepping from two threads take turns on the cores (the ``workqueue`` threading
layer, numba's fallback when neither TBB nor an OpenMP runtime is present, aborts the
process on concurrent launches). The kernel holds no GIL. OpenMP's idle threads sleep rather
than spin (``OMP_WAIT_POLICY=PASSIVE`` unless the environment says otherwise, set before the
runtime loads): a spinning thread takes its core from the other work of a busy machine, and
then every step waits for the thread that lost its core (measured on a loaded 2-CPU machine:
2 threads at 0.4-0.5× one thread spinning, about 1× sleeping).

``MIN_BODIES``: below this many moving bodies the serial stepping.advance runs (a parallel
launch costs a few µs a step; below this size it costs more than the second core gains).
Read when a simulator plans its bodies, so a test may lower it.
"""

from __future__ import annotations

import os
import threading

os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")  # before numba loads its OpenMP layer (see above)

import numba
import numpy as np
from numba import njit, prange

from .jit import JIT
from . import layout as L
from .layout import CUR, DONE, DT, LIMIT, METHOD, OK, OUTCOME, ROW_WIDTH, SPENT
from .stepping import SCRATCH_ROWS, _worse, add_pending, new_buffers, step_group, wrench_rows

__all__ = ["PARALLEL", "MIN_BODIES", "PART_BODIES", "max_threads", "parts_of", "advance_parallel", "run_parallel",
           "compile_parallel"]

#: JIT with numba's parallel loops (``prange``).
PARALLEL = {**JIT, "parallel": True}
#: Moving bodies from which the step runs in parallel (benchmarks/threads.py measures where it starts to pay).
MIN_BODIES = 8192
#: Bodies per part: large enough that a part costs far more than its scheduling.
PART_BODIES = 1024

_LOCK = threading.Lock()


def max_threads() -> int:
    """The most threads a step may use: numba's pool size (``NUMBA_NUM_THREADS``, by default the CPU count)."""
    return int(numba.config.NUMBA_NUM_THREADS)


def parts_of(groups: np.ndarray, part_bodies: int | None = None) -> np.ndarray:
    """The parts of a step, shape (P, 3) int64: [start, end) in ``members`` and the model code of each.

    ``groups`` (MODEL_COUNT, 2) are reduction.apply_plan's [start, end) per model; each non-empty
    group is cut into runs of at most ``part_bodies`` (default ``PART_BODIES``), in order.
    """
    part_bodies = PART_BODIES if part_bodies is None else part_bodies
    rows = []
    for model in range(groups.shape[0]):
        start, end = int(groups[model, 0]), int(groups[model, 1])
        for s in range(start, end, part_bodies):
            rows.append((s, min(s + part_bodies, end), model))
    return np.array(rows, dtype=np.int64).reshape(-1, 3)


@njit(**PARALLEL)
def advance_parallel(Ys, prm, wrenches, members, status, control, inputs, n_steps, cancel, parts):
    """stepping.advance with each step's ``parts`` (:func:`parts_of`) run in parallel; the same arguments and results.

    Only for a compiled integrator (control[METHOD] ≥ 0). Returns the number of steps done.
    """
    add_pending(wrenches, prm, inputs)
    rows = wrench_rows(wrenches)
    count = parts.shape[0]
    k = np.empty((count, SCRATCH_ROWS, ROW_WIDTH))
    deferred = np.empty(members.shape[0], dtype=np.int64)
    worst_of = np.empty(count, dtype=np.int64)
    method = control[METHOD]
    dt, limit = inputs[DT], inputs[LIMIT]
    cur = control[CUR]
    done = 0
    outcome = OK
    while done < n_steps and cancel[0] == 0:
        Y, Ynew = Ys[cur], Ys[1 - cur]
        for c in prange(count):
            start, end = parts[c, 0], parts[c, 1]
            worst_of[c] = step_group(method, parts[c, 2], Y, Ynew, prm, rows, members[start:end], status, dt,
                                     limit, k[c], deferred[start:end])
        outcome = OK
        for c in range(count):
            outcome = _worse(outcome, worst_of[c])
        if outcome != OK:
            break
        cur = 1 - cur
        control[CUR] = cur
        done += 1
    if outcome == OK:
        inputs[SPENT] = 1.0
    control[DONE] = done
    control[OUTCOME] = outcome
    return done


def run_parallel(threads: int, Ys, prm, wrenches, members, status, control, inputs, n_steps: int, cancel,
                 parts) -> int:
    """:func:`advance_parallel` on ``threads`` threads (1 ≤ threads ≤ :func:`max_threads`), one call at a time."""
    with _LOCK:
        numba.set_num_threads(threads)
        return advance_parallel(Ys, prm, wrenches, members, status, control, inputs, n_steps, cancel, parts)



def compile_parallel() -> None:
    """Compile (or load from numba's cache) :func:`advance_parallel` with the argument types the Simulator passes.

    With one body's buffers built as the Simulator builds them (kernels/compile.py does the
    same for the serial entry points); ``make venv`` and the node's first start call it
    through core/simulator.compile_kernels.
    """
    n = 1
    Ys, status, control, inputs = new_buffers(n)
    prm = np.zeros((n, L.PRM_WIDTH))
    prm[:, L.MASS] = prm[:, L.INV_MASS] = 1.0
    prm[:, L.INERTIA:L.INERTIA + 3] = prm[:, L.INV_INERTIA:L.INV_INERTIA + 3] = 1.0
    Ys[:, :, L.Q] = 1.0
    groups = np.zeros((L.MODEL_COUNT, 2), dtype=np.int64)
    groups[L.MODEL_FULL] = (0, n)
    control[L.GROUPS:L.GROUPS + groups.size] = groups.ravel()
    inputs[L.DT], inputs[L.LIMIT] = 0.01, np.inf
    run_parallel(1, Ys, prm, np.zeros((n, L.WRENCH_WIDTH)), np.arange(n, dtype=np.int64), status, control, inputs,
                 1, np.zeros(1, dtype=np.int64), parts_of(groups))
