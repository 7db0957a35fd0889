"""Where our compiled step loses time against the plain loop: the floor with our costs added one at a time.

At N = 1e4 tumbling boxes (the throughput problem), explicit Euler, ns per body-step, each a
numba loop over bodies (benchmarks/floors.py's step, written once below as ``_euler_row``):

0. ``floor``: in place on (N, 13) rows, inertia from an (N, 3) array;
1. ``+ parameter rows``: inertia read from (N, 40) parameter rows (our ``prm`` layout);
2. ``+ double buffer``: read Ys[cur], write Ys[1 − cur], flip (our two state buffers);
3. ``+ index list``: bodies visited through an int64 list ``members`` (our model grouping);
4. ``+ blow-up check``: per body after the step, non-finite test of the 13 numbers and the
   kinetic energy against the growing bound (our ``_check_body``), status written;
5. ``+ vector style``: the derivative written into a scratch row, then ``out[j] = y[j] + h d[j]``
   over 13 components (our ``_derivative`` / ``_step_euler`` style) instead of scalars;
6. ``+ full derivative``: what ours evaluates for every body whether or not a wrench acts
   (force/m from a zero wrench row, gravity and damping from the parameter row, the
   zero-torque test);
7. ``ours``: ``Simulator.step(n)``; then ``step(1)`` per step (the per-call cost: scratch
   allocated per call), ``rk4`` beside the rk4 floor, and 4b, the check of line 4 written as
   a balanced tree (a variant, not cumulative).

At N = 1 the question is the fixed cost of a call: ``sim.step(1)`` against a floor call from
Python (numba's dispatcher), and what allocating the kernel's scratch (an (N, 6) wrench array,
an (8, 13) scratch, an index list) costs per call.

Each line is the median of ≥ 5 interleaved samples (timing.py) with min–max. The variants are
cumulative, so the difference between two lines is what that one addition costs here.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from rigid_body_sim.core import Simulator

from .. import floors
from ..throughput import ANGULAR_VELOCITY, DT, INERTIA_BOX, scene
from ..timing import Case, interleaved

PRM_WIDTH = 40   # our parameter rows' width (kernels.PRM_WIDTH at the time of writing)
INERTIA = 2      # their inertia columns
LIMIT = 1e6      # the default energy_growth_limit


@njit(cache=True, inline="always")
def _euler_row(y, out, I1, I2, I3, dt):
    qw, qx, qy, qz = y[3], y[4], y[5], y[6]
    wx, wy, wz = y[10], y[11], y[12]
    hx, hy, hz = I1 * wx, I2 * wy, I3 * wz
    out[0] = y[0] + dt * y[7]
    out[1] = y[1] + dt * y[8]
    out[2] = y[2] + dt * y[9]
    nw = qw + dt * 0.5 * (-qx * wx - qy * wy - qz * wz)
    nx = qx + dt * 0.5 * (qw * wx + qy * wz - qz * wy)
    ny = qy + dt * 0.5 * (qw * wy - qx * wz + qz * wx)
    nz = qz + dt * 0.5 * (qw * wz + qx * wy - qy * wx)
    n = math.sqrt(nw * nw + nx * nx + ny * ny + nz * nz)
    out[3], out[4], out[5], out[6] = nw / n, nx / n, ny / n, nz / n
    out[7], out[8], out[9] = y[7], y[8], y[9]
    out[10] = wx - dt * (wy * hz - wz * hy) / I1
    out[11] = wy - dt * (wz * hx - wx * hz) / I2
    out[12] = wz - dt * (wx * hy - wy * hx) / I3


@njit(cache=True)
def v1_parameter_rows(Y, prm, dt, n_steps):
    for _ in range(n_steps):
        for i in range(Y.shape[0]):
            _euler_row(Y[i], Y[i], prm[i, INERTIA], prm[i, INERTIA + 1], prm[i, INERTIA + 2], dt)


@njit(cache=True)
def v2_double_buffer(Ys, prm, dt, n_steps, cur):
    for _ in range(n_steps):
        Y, Ynew = Ys[cur], Ys[1 - cur]
        for i in range(Y.shape[0]):
            _euler_row(Y[i], Ynew[i], prm[i, INERTIA], prm[i, INERTIA + 1], prm[i, INERTIA + 2], dt)
        cur = 1 - cur
    return cur


@njit(cache=True)
def v3_index_list(Ys, prm, members, dt, n_steps, cur):
    for _ in range(n_steps):
        Y, Ynew = Ys[cur], Ys[1 - cur]
        for m in range(members.shape[0]):
            i = members[m]
            _euler_row(Y[i], Ynew[i], prm[i, INERTIA], prm[i, INERTIA + 1], prm[i, INERTIA + 2], dt)
        cur = 1 - cur
    return cur


@njit(cache=True, inline="always")
def _check(row, p, budget, budget_new, status, i, dt, limit):
    poison = 0.0
    for j in range(13):
        poison += row[j] * 0.0
    if poison != 0.0:
        status[i] = 1
        return 1
    b = budget[i] + dt * p[10]
    budget_new[i] = b
    energy = 0.5 * (p[0] * (row[7] ** 2 + row[8] ** 2 + row[9] ** 2) + p[INERTIA] * row[10] ** 2
                    + p[INERTIA + 1] * row[11] ** 2 + p[INERTIA + 2] * row[12] ** 2)
    if energy > limit * b * b:
        status[i] = 2
        return 2
    status[i] = 0
    return 0


@njit(cache=True)
def v4_checks(Ys, prm, members, aux, dt, limit, n_steps, cur):
    for _ in range(n_steps):
        Y, Ynew = Ys[cur], Ys[1 - cur]
        worst = 0
        for m in range(members.shape[0]):
            i = members[m]
            p = prm[i]
            _euler_row(Y[i], Ynew[i], p[INERTIA], p[INERTIA + 1], p[INERTIA + 2], dt)
            worst = max(worst, _check(Ynew[i], p, aux[cur], aux[1 - cur], aux[2], i, dt, limit))
        if worst:
            return cur
        cur = 1 - cur
    return cur


@njit(cache=True, inline="always")
def _derivative_vector(y, p, d):
    qw, qx, qy, qz = y[3], y[4], y[5], y[6]
    wx, wy, wz = y[10], y[11], y[12]
    d[0], d[1], d[2] = y[7], y[8], y[9]
    d[3] = 0.5 * (-qx * wx - qy * wy - qz * wz)
    d[4] = 0.5 * (qw * wx + qy * wz - qz * wy)
    d[5] = 0.5 * (qw * wy - qx * wz + qz * wx)
    d[6] = 0.5 * (qw * wz + qx * wy - qy * wx)
    d[7] = d[8] = d[9] = 0.0
    I1, I2, I3 = p[INERTIA], p[INERTIA + 1], p[INERTIA + 2]
    hx, hy, hz = I1 * wx, I2 * wy, I3 * wz
    d[10] = -(wy * hz - wz * hy) / I1
    d[11] = -(wz * hx - wx * hz) / I2
    d[12] = -(wx * hy - wy * hx) / I3


@njit(cache=True)
def v5_vector_style(Ys, prm, members, aux, dt, limit, n_steps, cur):
    scratch = np.empty((8, 13))
    for _ in range(n_steps):
        Y, Ynew = Ys[cur], Ys[1 - cur]
        worst = 0
        d = scratch[0]
        for m in range(members.shape[0]):
            i = members[m]
            p = prm[i]
            y, out = Y[i], Ynew[i]
            _derivative_vector(y, p, d)
            for j in range(13):
                out[j] = y[j] + dt * d[j]
            n = math.sqrt(out[3] ** 2 + out[4] ** 2 + out[5] ** 2 + out[6] ** 2)
            out[3], out[4], out[5], out[6] = out[3] / n, out[4] / n, out[5] / n, out[6] / n
            worst = max(worst, _check(out, p, aux[cur], aux[1 - cur], aux[2], i, dt, limit))
        if worst:
            return cur
        cur = 1 - cur
    return cur


@njit(cache=True, inline="always")
def _check_tree(row, p, budget, budget_new, status, i, dt, limit):
    """_check with the non-finite test as a balanced tree of x·0 (4 levels of adds, not a 13-long chain)."""
    a = (row[0] * 0.0 + row[1] * 0.0) + (row[2] * 0.0 + row[3] * 0.0)
    b = (row[4] * 0.0 + row[5] * 0.0) + (row[6] * 0.0 + row[7] * 0.0)
    c = (row[8] * 0.0 + row[9] * 0.0) + (row[10] * 0.0 + row[11] * 0.0)
    if (a + b) + (c + row[12] * 0.0) != 0.0:
        status[i] = 1
        return 1
    b_new = budget[i] + dt * p[10]
    budget_new[i] = b_new
    energy = 0.5 * (p[0] * (row[7] ** 2 + row[8] ** 2 + row[9] ** 2) + p[INERTIA] * row[10] ** 2
                    + p[INERTIA + 1] * row[11] ** 2 + p[INERTIA + 2] * row[12] ** 2)
    if energy > limit * b_new * b_new:
        status[i] = 2
        return 2
    status[i] = 0
    return 0


@njit(cache=True)
def v4b_checks_tree(Ys, prm, members, aux, dt, limit, n_steps, cur):
    """v4 with the tree-shaped non-finite test (a variant, not cumulative)."""
    for _ in range(n_steps):
        Y, Ynew = Ys[cur], Ys[1 - cur]
        worst = 0
        for m in range(members.shape[0]):
            i = members[m]
            p = prm[i]
            _euler_row(Y[i], Ynew[i], p[INERTIA], p[INERTIA + 1], p[INERTIA + 2], dt)
            worst = max(worst, _check_tree(Ynew[i], p, aux[cur], aux[1 - cur], aux[2], i, dt, limit))
        if worst:
            return cur
        cur = 1 - cur
    return cur


@njit(cache=True, inline="always")
def _derivative_full(y, p, F, T, d):
    """As _derivative_vector, plus what ours evaluates for every body: force/m, gravity, damping, torque into P."""
    qw, qx, qy, qz = y[3], y[4], y[5], y[6]
    wx, wy, wz = y[10], y[11], y[12]
    d[0], d[1], d[2] = y[7], y[8], y[9]
    d[3] = 0.5 * (-qx * wx - qy * wy - qz * wz)
    d[4] = 0.5 * (qw * wx + qy * wz - qz * wy)
    d[5] = 0.5 * (qw * wy - qx * wz + qz * wx)
    d[6] = 0.5 * (qw * wz + qx * wy - qy * wx)
    inv_m = p[1]
    rate = p[5] * inv_m
    d[7] = F[0] * inv_m + p[7] - rate * y[7]
    d[8] = F[1] * inv_m + p[8] - rate * y[8]
    d[9] = F[2] * inv_m + p[9] - rate * y[9]
    if T[0] == 0.0 and T[1] == 0.0 and T[2] == 0.0:
        tx = ty = tz = 0.0
    else:
        n = math.sqrt(qw * qw + qx * qx + qy * qy + qz * qz)
        uw, ux, uy, uz = qw / n, -qx / n, -qy / n, -qz / n
        cx = 2.0 * (uy * T[2] - uz * T[1])
        cy = 2.0 * (uz * T[0] - ux * T[2])
        cz = 2.0 * (ux * T[1] - uy * T[0])
        tx = T[0] + uw * cx + (uy * cz - uz * cy)
        ty = T[1] + uw * cy + (uz * cx - ux * cz)
        tz = T[2] + uw * cz + (ux * cy - uy * cx)
    I1, I2, I3 = p[INERTIA], p[INERTIA + 1], p[INERTIA + 2]
    c = p[6]
    hx, hy, hz = I1 * wx, I2 * wy, I3 * wz
    d[10] = (tx - c * wx - (wy * hz - wz * hy)) / I1
    d[11] = (ty - c * wy - (wz * hx - wx * hz)) / I2
    d[12] = (tz - c * wz - (wx * hy - wy * hx)) / I3


@njit(cache=True)
def v6_full_derivative(Ys, prm, members, aux, dt, limit, n_steps, cur):
    """v5 with ours' whole derivative (force, gravity, damping, torque test) on a zero wrench row."""
    scratch = np.empty((8, 13))
    for _ in range(n_steps):
        Y, Ynew = Ys[cur], Ys[1 - cur]
        zero = np.zeros(6)
        worst = 0
        d = scratch[0]
        for m in range(members.shape[0]):
            i = members[m]
            p = prm[i]
            y, out = Y[i], Ynew[i]
            _derivative_full(y, p, zero[0:3], zero[3:6], d)
            for j in range(13):
                out[j] = y[j] + dt * d[j]
            n = math.sqrt(out[3] ** 2 + out[4] ** 2 + out[5] ** 2 + out[6] ** 2)
            out[3], out[4], out[5], out[6] = out[3] / n, out[4] / n, out[5] / n, out[6] / n
            worst = max(worst, _check(out, p, aux[cur], aux[1 - cur], aux[2], i, dt, limit))
        if worst:
            return cur
        cur = 1 - cur
    return cur


@njit(cache=True)
def allocate_scratch(count):
    """What a kernel call allocates before stepping: (N, 6) wrenches, (8, 13) scratch, an index list."""
    FT = np.zeros((count, 6))
    scratch = np.empty((8, 13))
    fallback = np.empty(count, dtype=np.int64)
    return FT.shape[0] + scratch.shape[0] + fallback.shape[0]


@njit(cache=True)
def nothing(count):
    return count


def _state(count: int):
    Y0 = floors.initial_rows(count, ANGULAR_VELOCITY)
    prm = np.zeros((count, PRM_WIDTH))
    prm[:, 0] = 2.0
    prm[:, INERTIA:INERTIA + 3] = INERTIA_BOX
    aux = np.zeros((3, count))
    energy0 = 0.5 * float(INERTIA_BOX @ ANGULAR_VELOCITY ** 2)
    aux[0:2] = math.sqrt(energy0)
    return Y0, prm, aux


def _cases_large(count: int) -> list[Case]:
    Y0, prm, aux0 = _state(count)
    inertia = np.tile(INERTIA_BOX, (count, 1))
    Y = Y0.copy()
    Ys = np.zeros((2, count, 13))
    aux = aux0.copy()
    members = np.arange(count, dtype=np.int64)

    def reset() -> None:
        Y[:] = Y0
        Ys[0] = Y0
        Ys[1] = Y0
        aux[:] = aux0

    reset()
    floors.euler_floor(Y, inertia, DT, 1)
    v1_parameter_rows(Y, prm, DT, 1)
    v2_double_buffer(Ys, prm, DT, 1, 0)
    v3_index_list(Ys, prm, members, DT, 1, 0)
    v4_checks(Ys, prm, members, aux, DT, LIMIT, 1, 0)
    v5_vector_style(Ys, prm, members, aux, DT, LIMIT, 1, 0)
    v6_full_derivative(Ys, prm, members, aux, DT, LIMIT, 1, 0)
    v4b_checks_tree(Ys, prm, members, aux, DT, LIMIT, 1, 0)
    s = scene(count)
    ours = {name: Simulator(s, integrator=name, dt=DT, threads=1) for name in ("euler", "rk4")}
    return [
        Case("0 floor (euler)", lambda k: floors.euler_floor(Y, inertia, DT, k), reset),
        Case("1 + parameter rows", lambda k: v1_parameter_rows(Y, prm, DT, k), reset),
        Case("2 + double buffer", lambda k: v2_double_buffer(Ys, prm, DT, k, 0), reset),
        Case("3 + index list", lambda k: v3_index_list(Ys, prm, members, DT, k, 0), reset),
        Case("4 + blow-up check", lambda k: v4_checks(Ys, prm, members, aux, DT, LIMIT, k, 0), reset),
        Case("5 + vector style", lambda k: v5_vector_style(Ys, prm, members, aux, DT, LIMIT, k, 0), reset),
        Case("6 + full derivative", lambda k: v6_full_derivative(Ys, prm, members, aux, DT, LIMIT, k, 0), reset),
        Case("7 ours euler step(n)", ours["euler"].step, ours["euler"].reset),
        Case("4b = 4, tree-shaped non-finite test", lambda k: v4b_checks_tree(Ys, prm, members, aux, DT, LIMIT, k, 0),
             reset),
        Case("ours euler step(1) per step", lambda k: [ours["euler"].step(1) for _ in range(k)], ours["euler"].reset),
        Case("floor rk4", lambda k: floors.rk4_floor(Y, inertia, DT, k), reset),
        Case("ours rk4 step(n)", ours["rk4"].step, ours["rk4"].reset),
    ]


def _cases_one() -> list[Case]:
    Y0, _prm, _aux = _state(1)
    inertia = INERTIA_BOX[None, :].copy()
    Y = Y0.copy()
    sim = Simulator(scene(1), integrator="euler", dt=DT)
    step = sim.step
    allocate_scratch(1)
    nothing(1)

    def loop(f):
        def run(k: int) -> None:
            for _ in range(k):
                f()
        return run
    return [
        Case("floor euler, one call of 1 step", loop(lambda: floors.euler_floor(Y, inertia, DT, 1)), lambda: None),
        Case("a numba call doing nothing", loop(lambda: nothing(1)), lambda: None),
        Case("a numba call allocating the kernel's scratch", loop(lambda: allocate_scratch(1)), lambda: None),
        Case("ours sim.step(1)", loop(lambda: step(1)), sim.reset),
        Case("ours sim.step(k), per step", step, sim.reset),
    ]


def report(repeats: int = 5, min_seconds: float = 0.05, count: int = 10_000, log=print) -> str:
    large = interleaved(_cases_large(count), repeats, min_seconds)
    one = interleaved(_cases_one(), repeats, min_seconds)
    lines = [__doc__, f"N = {count:g}, ns per body-step, median (min–max); Δ = change from the line above "
                      "(cumulative lines only), of the medians and of the minimums (the least disturbed samples):\n"]
    previous = None
    for key, s in large.items():
        ns = s.scaled(1e9 / count)
        cumulative = key[:2].strip().isdigit()
        delta = ""
        if cumulative and previous is not None:
            delta = f"   Δ {ns.median - previous.median:+.3g} / {ns.low - previous.low:+.3g}"
        lines.append(f"  {key:<38} {ns.text():<28}{delta}")
        if cumulative:
            previous = ns
    lines.append("\nN = 1, µs per call, median (min–max):\n")
    for key, s in one.items():
        lines.append(f"  {key:<46} {s.scaled(1e6).text()}")
    log("  kernel profile done")
    return "\n".join(lines) + "\n"

