"""The compiled step driver: every moving body, its model or the integrator, then the blow-up checks.

One call of :func:`advance` runs ``n`` steps of every moving body (numba; no Python per step
or per body). Per step, for each model's group of bodies (core/reduction.py groups them, so each
loop is homogeneous and static bodies are never touched), the body's model
(reduced_models.py) or the integrator (integrators.py, dispatched by integrate) writes the next state into
the other state buffer; :func:`check_body` then checks it (finite; kinetic energy within the
bound of core/simulator.DivergenceError). Only when every body passes does the other buffer become
the current one, so a failed step is never applied.

Buffers (layout.py names every column):

``Ys`` : (2, N, ROW_WIDTH)
    The state rows, twice: ``control[CUR]`` says which holds the state.
``prm`` : (N, PRM_WIDTH)
    Per-body constants (core/stepping.pack_parameters, then core/reduction.apply_plan).
``wrenches`` : (N, WRENCH_WIDTH)
    Applied wrenches in frame terms (forces.add_wrench); held for every step of the call and
    cleared at its end.
``members`` : (M,) int64
    The moving bodies, grouped by model; ``control[GROUPS + 2c : GROUPS + 2c + 2]`` is the
    [start, end) of model c's group.
``status`` : (N,) int64
    Each body's outcome of the last step checked.
``control`` : (CONTROL_WIDTH,) int64, ``inputs`` : (INPUT_WIDTH,) float64
    The current buffer, the method, steps done and the outcome; dt, the limit, a pending wrench.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from .forces import add_wrench
from .integrators import COMPILED
from .layout import (
    ACTIVE,
    BOUND,
    BUDGET_FORCE,
    BUDGET_TORQUE,
    CONTROL_WIDTH,
    CUR,
    DIVERGED,
    DONE,
    DT,
    F_COM_P,
    F_COM_W,
    F_WORLD,
    GRAVITY,
    GRAVITY_BUDGET_RATE,
    GROUPS,
    INERTIA,
    INPUT_WIDTH,
    LIMIT,
    MASS,
    METHOD,
    MODEL_COUNT,
    MODEL_FULL,
    MODEL_ISOTROPIC,
    MODEL_KINEMATIC,
    MODEL_PLANAR,
    MODEL_SYMMETRIC,
    MODEL_TRANSLATION,
    NON_FINITE,
    OK,
    OUTCOME,
    P,
    PENDING,
    PENDING_ARM,
    PENDING_BODY,
    PENDING_FORCE,
    PENDING_FRAME,
    PENDING_TORQUE,
    Q,
    ROW_WIDTH,
    SITE_MOMENT,
    SPENT,
    T_COM_P,
    T_COM_W,
    T_WORLD,
    V,
    W,
)
from .reduced_models import isotropic_free, kinematic, planar, symmetric_free, torque_free, translation
from .jit import INLINE, JIT, LOOP, named

__all__ = ["new_buffers", "advance", "advance_in", "add_pending", "step_reduced", "check_members", "clear_wrenches", "wrench_rows",
           "integrate", "step_group"]

#: Rows of the per-call scratch: stage derivatives and the stage state of the longest tableau.
SCRATCH_ROWS = 6


def new_buffers(count: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(Ys, status, control, inputs) for ``count`` bodies, as :func:`advance` takes them."""
    return (np.zeros((2, count, ROW_WIDTH)), np.zeros(count, dtype=np.int64),
            np.zeros(CONTROL_WIDTH, dtype=np.int64), np.zeros(INPUT_WIDTH))


# ----------------------------------------------------------------------------- checks


@njit(**INLINE)
def energy_bound_rate(y, p, w):
    """d√K/dt can be at most this (see simulator.DivergenceError): |F + m g|/√(2m) + |τ|/√(2 I_min).

    From the wrench row in frame terms with norms a rotation does not change, so it bounds the
    power of the whole step, whatever the body does in it (the moment arm of a force about a
    world point is taken at the step's start).
    """
    rate = p[GRAVITY_BUDGET_RATE]
    if w[ACTIVE] != 0.0:
        rate = _wrench_budget_rate(y, p, w)
    _pin = y[P], p[0], w[0]  # the arrays' last use, out of branches and loops (jit.py)
    return rate


@njit(**INLINE)
def _wrench_budget_rate(y, p, w):
    """energy_bound_rate of a body with an applied wrench."""
    m = p[MASS]
    f0, f1, f2 = w[F_WORLD], w[F_WORLD + 1], w[F_WORLD + 2]
    force = (math.sqrt((f0 + w[F_COM_W] + m * p[GRAVITY]) ** 2 + (f1 + w[F_COM_W + 1] + m * p[GRAVITY + 1]) ** 2
                       + (f2 + w[F_COM_W + 2] + m * p[GRAVITY + 2]) ** 2)
             + math.sqrt(w[F_COM_P] ** 2 + w[F_COM_P + 1] ** 2 + w[F_COM_P + 2] ** 2))
    px, py, pz = y[P], y[P + 1], y[P + 2]
    sites = 0.0
    for j in range(9):
        sites += w[SITE_MOMENT + j] ** 2
    torque = (math.sqrt((w[T_WORLD] - (py * f2 - pz * f1)) ** 2 + (w[T_WORLD + 1] - (pz * f0 - px * f2)) ** 2
                        + (w[T_WORLD + 2] - (px * f1 - py * f0)) ** 2)
              + math.sqrt(w[T_COM_W] ** 2 + w[T_COM_W + 1] ** 2 + w[T_COM_W + 2] ** 2)
              + math.sqrt(w[T_COM_P] ** 2 + w[T_COM_P + 1] ** 2 + w[T_COM_P + 2] ** 2)
              + math.sqrt(2.0 * sites))
    _pin = y[P], p[0], w[0]  # the arrays' last use, out of branches and loops (jit.py)
    return force * p[BUDGET_FORCE] + torque * p[BUDGET_TORQUE]


@njit(**INLINE)
def finite_row(y):
    """True when all 13 state numbers of row ``y`` are finite.

    x·0 is 0 for a finite x and NaN for inf or NaN; the products are summed as a tree (depth
    4, not a chain of 13 dependent additions). check_body's rule for a row that fails its sum.
    """
    a = (y[0] * 0.0 + y[1] * 0.0) + (y[2] * 0.0 + y[3] * 0.0)
    b = (y[4] * 0.0 + y[5] * 0.0) + (y[6] * 0.0 + y[7] * 0.0)
    c = (y[8] * 0.0 + y[9] * 0.0) + (y[10] * 0.0 + y[11] * 0.0)
    return (a + b) + (c + y[12] * 0.0) == 0.0


@njit(**INLINE)
def check_body(y, out, p, w, dt, limit):
    """Outcome of one body's step y → out: NON_FINITE, DIVERGED (kinetic energy > limit·B²) or OK; sets out's bound B."""
    # The new row is read first, straight after the step wrote it: the compiler then keeps the
    # numbers in registers instead of reading them back after the bound's branch below.
    v2 = out[V] * out[V] + out[V + 1] * out[V + 1] + out[V + 2] * out[V + 2]
    energy = 0.5 * (p[MASS] * v2 + p[INERTIA] * out[W] ** 2 + p[INERTIA + 1] * out[W + 1] ** 2
                    + p[INERTIA + 2] * out[W + 2] ** 2)
    # The energy is a sum of m·v_i² and I_i·w_i², none negative, so it is finite only if v and w
    # are; a sum is finite only if every term is. So when s, the sum of p, q and the energy, is
    # finite, the row is (s − s is then 0, else NaN): one test of the common case, which also
    # compares the energy with the limit. A finite row whose s overflows goes the long way.
    s = ((out[P] + out[P + 1]) + (out[P + 2] + out[Q])) + ((out[Q + 1] + out[Q + 2]) + (out[Q + 3] + energy))
    bound = y[BOUND] + dt * energy_bound_rate(y, p, w)
    out[BOUND] = bound
    outcome = OK
    if not energy + (s - s) <= limit * bound * bound:  # NaN compares false: the long way, the rule itself
        if not finite_row(out):
            outcome = NON_FINITE
        elif energy > limit * bound * bound:
            outcome = DIVERGED
    _pin = y[P], out[P], p[0], w[0]  # the arrays' last use, out of branches and loops (jit.py)
    return outcome


@njit(**JIT)
def _worse(a, b):
    """The worse of two outcomes: NON_FINITE over DIVERGED over OK."""
    if a == NON_FINITE or b == NON_FINITE:
        return NON_FINITE
    return max(a, b)


# One bit per failed outcome, so a loop can gather its bodies' outcomes with one OR each (_worst_seen).
assert (OK, NON_FINITE, DIVERGED) == (0, 1, 2)


@njit(**JIT)
def _worst_seen(seen):
    """The worst of the outcomes OR-ed into ``seen``: the same as :func:`_worse` over them."""
    return NON_FINITE if seen & NON_FINITE else seen


# ----------------------------------------------------------------------------- one step of every moving body


#: control[METHOD] of the numpy/scipy integrators: the step loop leaves their bodies to the caller.
HOST_METHOD = -1


def _group_loop(step, when_torque_free=False):
    """A compiled loop that steps and checks ``bodies`` with the per-body ``step``, inlined into it.

    One loop per method or model rather than a branch per body: each loop body is then
    straight-line code, which the compiler keeps free of reference counting (jit.py; measured
    ~70 ns a body otherwise). ``step`` is a free variable of the loop, a constant to numba, so
    ``INLINE`` inlines it as it would a global. Not cached on its own (numba keys a closure's
    cache on its free variables, which a compiled function cannot be pickled stably as): it is
    compiled into the cached functions that call it, named after ``step`` (jit.named).

    ``when_torque_free`` (the isotropic and symmetric models): a body under a torque
    (reduced_models.torque_free) is not the model's: it goes into ``deferred`` for the
    integrator, which rewrites its row. The model still runs on it (unconditionally, jit.py).
    Returns (worst outcome, how many were deferred).
    """
    if when_torque_free:
        @njit(**LOOP)
        @named(step.__name__)
        def loop(Y, Ynew, prm, wrenches, bodies, status, dt, limit, k, deferred):
            seen = OK
            count = 0
            last = np.uint64(wrenches.shape[0] - 1)
            for m in range(np.uint64(bodies.shape[0])):  # unsigned: m and i index without wraparound code
                i = np.uint64(bodies[m])  # an index (≥ 0): unsigned, so no negative-index wraparound per array
                y, out, p, w = Y[i], Ynew[i], prm[i], wrenches[min(i, last)]  # one row for all: see wrench_rows
                free = torque_free(w)
                step(y, out, p, w, dt, k)
                outcome = check_body(y, out, p, w, dt, limit)
                if free:
                    status[i] = outcome
                    seen |= outcome
                else:
                    deferred[count] = i
                    count += 1
            return _worst_seen(seen), count
    else:
        @njit(**LOOP)
        @named(step.__name__)
        def loop(Y, Ynew, prm, wrenches, bodies, status, dt, limit, k, deferred):
            seen = OK
            last = np.uint64(wrenches.shape[0] - 1)
            for m in range(np.uint64(bodies.shape[0])):  # unsigned: m and i index without wraparound code
                i = np.uint64(bodies[m])  # an index (≥ 0): unsigned, so no negative-index wraparound per array
                y, out, p, w = Y[i], Ynew[i], prm[i], wrenches[min(i, last)]  # one row for all: see wrench_rows
                step(y, out, p, w, dt, k)
                outcome = check_body(y, out, p, w, dt, limit)
                status[i] = outcome
                seen |= outcome  # the worst at the end (_worst_seen): one OR a body, not _worse's compares
            return _worst_seen(seen), 0

    return loop


@njit(**LOOP)
def _no_loop(Y, Ynew, prm, wrenches, bodies, status, dt, limit, k, deferred):
    """The loop of a code with no per-body step (model full: the integrator's; static: never stepped)."""
    return OK, 0


def _dispatch_from(chain, loops, code=0):
    """``dispatch(code, ...)``: runs ``loops[code]``, as a chain of compiled calls from ``code`` on.

    Each link holds one loop and the rest of the chain as free variables (direct calls, no
    function-typed values); it runs once per group per step, not per body. ``chain`` names the
    chain, each link ``dispatch[chain code]`` (jit.named).
    """
    if code == len(loops):
        @njit(**LOOP)
        @named(f"{chain} end")
        def dispatch(which, Y, Ynew, prm, wrenches, bodies, status, dt, limit, k, deferred):
            return OK, 0
    else:
        loop, rest = loops[code], _dispatch_from(chain, loops, code + 1)

        @njit(**LOOP)
        @named(f"{chain} {code}")
        def dispatch(which, Y, Ynew, prm, wrenches, bodies, status, dt, limit, k, deferred):
            if which == code:
                result = loop(Y, Ynew, prm, wrenches, bodies, status, dt, limit, k, deferred)
            else:
                result = rest(which, Y, Ynew, prm, wrenches, bodies, status, dt, limit, k, deferred)
            return result
    return dispatch


#: The loops of the compiled integrators, built from integrators.INTEGRATORS (by Method.code).
_INTEGRATOR_LOOPS = _dispatch_from("integrators", tuple(_group_loop(step) for step in COMPILED))

#: The reduced models' loops, by layout.MODEL_* code.
_MODEL_STEPS = {MODEL_KINEMATIC: (kinematic, False), MODEL_TRANSLATION: (translation, False),
                MODEL_PLANAR: (planar, False), MODEL_ISOTROPIC: (isotropic_free, True),
                MODEL_SYMMETRIC: (symmetric_free, True)}
_MODEL_LOOPS = _dispatch_from("models", tuple(_group_loop(*_MODEL_STEPS[code]) if code in _MODEL_STEPS
                                              else _no_loop for code in range(MODEL_COUNT)))


@njit(**JIT)
def integrate(method, Y, Ynew, prm, wrenches, bodies, status, dt, limit, k):
    """Step and check ``bodies`` with the compiled integrator ``method`` (Method.code); the worst outcome."""
    worst, _ = _INTEGRATOR_LOOPS(method, Y, Ynew, prm, wrenches, bodies, status, dt, limit, k, bodies)  # defers none
    return worst


@njit(**JIT)
def step_group(method, model, Y, Ynew, prm, wrenches, bodies, status, dt, limit, k, deferred):
    """One step of ``bodies``, all of model ``model``, with the compiled integrator ``method``; the worst outcome.

    Model full: the integrator. A reduced model: its loop, then the integrator on the bodies it
    deferred (a torque acts on them), which ``deferred`` (at least as long as ``bodies``) holds.
    Every body's step reads only its own rows and writes only its own rows and status, so any
    split of a group into parts (parallel.py) steps each body exactly as the whole group does.
    """
    if model == MODEL_FULL:
        worst = integrate(method, Y, Ynew, prm, wrenches, bodies, status, dt, limit, k)
    else:
        worst, added = _MODEL_LOOPS(model, Y, Ynew, prm, wrenches, bodies, status, dt, limit, k, deferred)
        if added:
            worst = _worse(worst, integrate(method, Y, Ynew, prm, wrenches, deferred[:added], status, dt, limit, k))
    return worst


@njit(**JIT)
def _step_all(method, Y, Ynew, prm, wrenches, members, control, status, dt, limit, k, deferred):
    """One step of every moving body, group by group; returns (worst outcome, bodies left in ``deferred``).

    With HOST_METHOD the integrator's bodies (model full, and the deferred reduced ones) are
    left in ``deferred`` unstepped, for a numpy/scipy integrator.
    """
    worst = OK
    count = 0
    for model in range(MODEL_COUNT):
        start, end = control[GROUPS + 2 * model], control[GROUPS + 2 * model + 1]
        if start < end and method != HOST_METHOD:
            worst = _worse(worst, step_group(method, model, Y, Ynew, prm, wrenches, members[start:end], status, dt,
                                             limit, k, deferred))
        elif start < end and model == MODEL_FULL:
            deferred[count:count + end - start] = members[start:end]
            count += end - start
        elif start < end:
            outcome, added = _MODEL_LOOPS(model, Y, Ynew, prm, wrenches, members[start:end], status, dt,
                                          limit, k, deferred[count:])
            worst = _worse(worst, outcome)
            count += added
    return worst, count


@njit(**JIT)
def add_pending(wrenches, prm, inputs):
    """Move the pending wrench of ``inputs`` (Simulator.apply_*'s fast path) into its body's wrench row.

    First, if the rows hold the last step's wrenches (inputs[SPENT]), they are dropped: a step's
    wrenches stay in the rows after it, for the sensors to read (sensors.py), until something
    new is applied or stepped.
    """
    if inputs[SPENT] != 0.0:
        clear_wrenches(wrenches)
        inputs[SPENT] = 0.0
    if inputs[PENDING] != 0.0:
        b = int(inputs[PENDING_BODY])
        add_wrench(wrenches[b], prm[b], int(inputs[PENDING_FRAME]), inputs[PENDING_ARM], inputs[PENDING_ARM + 1],
                   inputs[PENDING_ARM + 2], inputs[PENDING_FORCE], inputs[PENDING_FORCE + 1],
                   inputs[PENDING_FORCE + 2], inputs[PENDING_TORQUE], inputs[PENDING_TORQUE + 1],
                   inputs[PENDING_TORQUE + 2])
        inputs[PENDING] = 0.0


@njit(**JIT)
def wrench_rows(wrenches):
    """The wrench rows the group loops read: ``wrenches``, or its first row alone when no row holds anything.

    Every reader of a wrench row ignores a row whose ACTIVE is zero (forces.body_wrench,
    energy_bound_rate, reduced_models.torque_free), and such a row is all zeros; so when no row
    is active every body may read the same one, which stays in cache, instead of a row of its
    own. The loops read row min(i, rows − 1): body i's own row, or that one row.
    """
    rows = wrenches[:1]
    for i in range(wrenches.shape[0]):
        if wrenches[i, ACTIVE] != 0.0:
            rows = wrenches
            break
    return rows


@njit(**JIT)
def clear_wrenches(wrenches):
    """Zero every wrench row that holds something."""
    for i in range(wrenches.shape[0]):
        if wrenches[i, ACTIVE] != 0.0:
            wrenches[i, :] = 0.0


@njit(**JIT)
def advance(Ys, prm, wrenches, members, status, control, inputs, n_steps, cancel):
    """Up to ``n_steps`` checked steps of every moving body with the compiled integrator control[METHOD].

    Adds the pending wrench first (:func:`add_pending`). Stops at the first step some body
    fails: that step is not applied (the state and its bounds stay in Ys[control[CUR]]),
    ``status`` says which bodies failed how, and the wrenches are kept. Stops too, between
    two steps, once ``cancel[0]`` (an int64 array another thread may set while this runs:
    the function holds no GIL) is not zero; the steps done stand. Otherwise, and when
    cancelled, the wrenches are then spent (inputs[SPENT]): they stay in the rows for the
    sensors and are dropped before the next step or the next wrench. Reports control[DONE]
    and control[OUTCOME] (OK, NON_FINITE, DIVERGED); returns the number of steps done.
    """
    return advance_in(Ys, prm, wrenches, members, status, control, inputs, n_steps, cancel,
                      np.empty((SCRATCH_ROWS, ROW_WIDTH)), np.empty(members.shape[0], dtype=np.int64))


@njit(**JIT)
def advance_in(Ys, prm, wrenches, members, status, control, inputs, n_steps, cancel, k, deferred):
    """:func:`advance` with its scratch given (what it allocates per call): ``k`` (SCRATCH_ROWS, ROW_WIDTH)
    float64 and ``deferred`` int64 of at least ``members``' length; their contents do not matter."""
    add_pending(wrenches, prm, inputs)
    rows = wrench_rows(wrenches)
    cur = control[CUR]
    done = 0
    outcome = OK
    while done < n_steps and cancel[0] == 0:
        outcome, _ = _step_all(control[METHOD], Ys[cur], Ys[1 - cur], prm, rows, members, control, status,
                               inputs[DT], inputs[LIMIT], k, deferred)
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


@njit(**JIT)
def step_reduced(Ys, prm, wrenches, members, status, control, inputs):
    """One step of the bodies the reduced models take; returns the bodies left for the numpy/scipy integrator.

    Ys[1 − CUR] ← the reduced models' step; the returned indices (model full, and isotropic
    or symmetric bodies under a torque) are the caller's to step. :func:`check_members`
    checks them all afterwards.
    """
    add_pending(wrenches, prm, inputs)
    k = np.empty((SCRATCH_ROWS, ROW_WIDTH))
    deferred = np.empty(members.shape[0], dtype=np.int64)
    cur = control[CUR]
    _, count = _step_all(HOST_METHOD, Ys[cur], Ys[1 - cur], prm, wrenches, members, control, status, inputs[DT],
                         inputs[LIMIT], k, deferred)
    return deferred[:count].copy()


@njit(**JIT)
def check_members(Ys, prm, wrenches, members, status, control, inputs):
    """Check every moving body's step Ys[CUR] → Ys[1 − CUR]; commit it (flip CUR) if all pass. The outcome."""
    dt, limit = inputs[DT], inputs[LIMIT]
    cur = control[CUR]
    Y, Ynew = Ys[cur], Ys[1 - cur]
    worst = OK
    for m in range(members.shape[0]):
        i = members[m]
        status[i] = check_body(Y[i], Ynew[i], prm[i], wrenches[i], dt, limit)
        worst = _worse(worst, status[i])
    control[OUTCOME] = worst
    control[DONE] = 1 if worst == OK else 0
    if worst == OK:
        control[CUR] = 1 - cur
    return worst
