"""One step of a serial scene through one compiled entry point of one argument, called through ctypes.

numba's dispatcher types and unboxes every argument of every call; stepping.advance takes ten
(controls.advance_controlled eleven), which costs a ``step(1)`` of one body about ten times
what the step itself computes. :func:`step_block` is a ``numba.cfunc`` (a C function, numba's
public API for callbacks) of one pointer, to a block of the buffers' addresses
(:func:`new_block`); it rebuilds the arrays in place with ``numba.carray`` and calls the very
same compiled stepping.advance_in, or controls.advance_controlled_in when a control table
exists (what stepping.advance and controls.advance_controlled call, after allocating their
scratch), with one step: the same machine code on the same buffers as Simulator.step's general
path, so the results are the same to the bit (test_single_step.py). The scratch is the
Simulator's own, allocated once.

Block (``BLOCK_WIDTH`` pointers, ``uintp``): the addresses of Ys, prm, wrenches, members,
status, control, inputs, cancel, the control table (0 when none), ``SIZES`` (the address of an
int64 array of (bodies, members, table rows)), then the scratch: ``k`` (SCRATCH_ROWS,
ROW_WIDTH), ``deferred`` (members) and a wrench row. The Simulator builds it whenever it
replaces one of these arrays (:func:`fill_block`) and keeps the arrays alive.

What the call does besides the step: it clears the cancel flag (Simulator.step's ``finally``).
It returns what the advance it calls returns. Through ``ctypes.CFUNCTYPE`` the call releases
the GIL, as the ``nogil`` kernels do.
"""

from __future__ import annotations

import ctypes

import numpy as np
from numba import carray, cfunc, types

from .controls import CONTROL_WIDTH as TABLE_WIDTH
from .controls import advance_controlled_in
from .jit import JIT
from .layout import CONTROL_WIDTH, INPUT_WIDTH, PRM_WIDTH, ROW_WIDTH, WRENCH_WIDTH
from .stepping import SCRATCH_ROWS, advance_in

__all__ = ["BLOCK_WIDTH", "SIZES", "new_block", "fill_block", "step_block", "entry"]

#: Slots of the block: the buffers' addresses, then the sizes array's.
YS, PRM, WRENCHES, MEMBERS, STATUS, CONTROL, INPUTS, CANCEL, TABLE, SIZES, K, DEFERRED, SCRATCH = range(13)
BLOCK_WIDTH = 13
#: Slots of the sizes array.
BODIES, MEMBER_COUNT, TABLE_ROWS = range(3)

_OPTIONS = {key: value for key, value in JIT.items() if key != "nogil"}  # a C function: no GIL of its own


@cfunc(types.int64(types.CPointer(types.voidptr)), **_OPTIONS)
def step_block(block):
    """One checked step of every moving body from the buffers ``block`` points at (see the module); the steps done."""
    sizes = carray(block[SIZES], (3,), dtype=np.int64)
    n, m, rows = sizes[BODIES], sizes[MEMBER_COUNT], sizes[TABLE_ROWS]
    Ys = carray(block[YS], (2, n, ROW_WIDTH), dtype=np.float64)
    prm = carray(block[PRM], (n, PRM_WIDTH), dtype=np.float64)
    wrenches = carray(block[WRENCHES], (n, WRENCH_WIDTH), dtype=np.float64)
    members = carray(block[MEMBERS], (m,), dtype=np.int64)
    status = carray(block[STATUS], (n,), dtype=np.int64)
    control = carray(block[CONTROL], (CONTROL_WIDTH,), dtype=np.int64)
    inputs = carray(block[INPUTS], (INPUT_WIDTH,), dtype=np.float64)
    cancel = carray(block[CANCEL], (1,), dtype=np.int64)
    k = carray(block[K], (SCRATCH_ROWS, ROW_WIDTH), dtype=np.float64)
    deferred = carray(block[DEFERRED], (m,), dtype=np.int64)
    if rows:
        table = carray(block[TABLE], (rows, TABLE_WIDTH), dtype=np.float64)
        scratch = carray(block[SCRATCH], (WRENCH_WIDTH,), dtype=np.float64)
        done = advance_controlled_in(Ys, prm, wrenches, members, status, control, inputs, 1, cancel, table, k,
                                     deferred, scratch)
    else:
        done = advance_in(Ys, prm, wrenches, members, status, control, inputs, 1, cancel, k, deferred)
    cancel[0] = 0
    return done


def new_block() -> tuple[np.ndarray, np.ndarray]:
    """(block, sizes): the pointer block and its sizes array, zero; :func:`fill_block` fills them."""
    block = np.zeros(BLOCK_WIDTH, dtype=np.uintp)
    sizes = np.zeros(3, dtype=np.int64)
    block[SIZES] = sizes.ctypes.data
    return block, sizes


def fill_block(block, sizes, Ys, prm, wrenches, members, status, control, inputs, cancel, table, k, deferred,
               scratch) -> None:
    """Point ``block`` at the buffers (stepping.advance's, C-contiguous, of its dtypes; ``table`` may be None)
    and the scratch (``k`` (SCRATCH_ROWS, ROW_WIDTH) float64, ``deferred`` int64 as long as ``members``,
    ``scratch`` (WRENCH_WIDTH,) float64).

    The caller keeps every array alive, and unchanged in shape, while the block may be called.
    """
    arrays = ((YS, Ys, np.float64, (2, -1, ROW_WIDTH)), (PRM, prm, np.float64, (-1, PRM_WIDTH)),
              (WRENCHES, wrenches, np.float64, (-1, WRENCH_WIDTH)), (MEMBERS, members, np.int64, (-1,)),
              (STATUS, status, np.int64, (-1,)), (CONTROL, control, np.int64, (CONTROL_WIDTH,)),
              (INPUTS, inputs, np.float64, (INPUT_WIDTH,)), (CANCEL, cancel, np.int64, (1,)),
              (K, k, np.float64, (SCRATCH_ROWS, ROW_WIDTH)), (DEFERRED, deferred, np.int64, (members.shape[0],)),
              (SCRATCH, scratch, np.float64, (WRENCH_WIDTH,)))
    for slot, array, dtype, shape in arrays:
        if (array.dtype != dtype or not array.flags.c_contiguous or array.ndim != len(shape)
                or any(s >= 0 and s != t for s, t in zip(shape, array.shape))):
            raise ValueError(f"single-step block: buffer {slot} has dtype {array.dtype}, shape {array.shape}; "
                             f"expected C-contiguous {np.dtype(dtype)} of shape {shape}")
    n = prm.shape[0]
    if Ys.shape[1] != n or wrenches.shape[0] != n or status.shape[0] != n:
        raise ValueError(f"single-step block: buffers of different body counts ({Ys.shape}, {prm.shape}, "
                         f"{wrenches.shape}, {status.shape})")
    for slot, array, _dtype, _shape in arrays:
        block[slot] = array.ctypes.data
    sizes[BODIES], sizes[MEMBER_COUNT] = n, members.shape[0]
    if table is None:
        block[TABLE], sizes[TABLE_ROWS] = 0, 0
    else:
        if table.dtype != np.float64 or not table.flags.c_contiguous or table.ndim != 2 or table.shape[1] != TABLE_WIDTH:
            raise ValueError(f"single-step block: control table of dtype {table.dtype}, shape {table.shape}")
        block[TABLE], sizes[TABLE_ROWS] = table.ctypes.data, table.shape[0]


_entry = None


def entry():
    """:func:`step_block` as a ctypes function of one address (an int), returning the steps done (int)."""
    global _entry
    if _entry is None:
        _entry = ctypes.CFUNCTYPE(ctypes.c_int64, ctypes.c_void_p)(step_block.address)
    return _entry
