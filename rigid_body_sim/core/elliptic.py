"""Jacobi elliptic functions and Legendre's elliptic integrals, to full precision near m = 1.

The shared elliptic helpers of the torque-free rotor (free_rotor.py) and of its closed-form
reference (rigid_body_sim/exact/closed_form.py), vectorised over numpy arrays (every argument broadcasts). The
parameter is always given as ``m_c = 1 − m`` (with ``m`` where a formula needs it), because
the interesting motions sit near the separatrix, m → 1, where ``1 − m`` cannot be recovered
from m. Amplitudes are passed as the triple ``(sin β, cos β, Δ = √(1 − m sin²β))`` where the
caller knows them from a state: near β = π/2 with m ≈ 1 the angle β itself would throw away
the relative accuracy of cos β and Δ, which is what every formula below needs.

* :func:`complete_k` — K(m) from m_c (``scipy.special.ellipkm1``).
* :func:`jacobi_reduced`, :func:`jacobi` — sn, cn, dn by Bulirsch's descending Landen
  recurrence on cn/sn (R. Bulirsch, Numer. Math. 7, 1965), which has no arcsin and so keeps
  cn and dn to relative accuracy where they are small (u near K, m near 1).
* :func:`reduce_phase` — u = 2K j + r with r ∈ [−K, K].
* :func:`elliptic_f`, :func:`elliptic_f_angle` — F(β | m) by Carlson's R_F.
* :func:`third_kind_minus_f`, :func:`third_kind_minus_f_complete` — Π(n; β | m) − F(β | m)
  by Carlson's R_J (``scipy.special.elliprf``/``elliprj``, which are accurate to a few ulp).
* :func:`two_product`, :func:`two_sum`, :func:`difference_of_products` — error-free
  transformations (Dekker, Knuth) for invariants that cancel, such as L² − 2E·I2.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "complete_k",
    "jacobi_reduced",
    "jacobi",
    "reduce_phase",
    "elliptic_f",
    "elliptic_f_angle",
    "third_kind_minus_f",
    "third_kind_minus_f_complete",
    "two_product",
    "two_sum",
    "difference_of_products",
]

#: Landen steps stop once |a − b| ≤ this · a; the recurrence then has an error ~ this², < 2^-53.
_AGM_RTOL = 2.0**-27
#: At most this many Landen steps (quadratic convergence: ~10 for m_c = 1e-300).
_AGM_MAX_STEPS = 40
#: Below this |u| the series sn = u, cn = 1 − u²/2, dn = 1 − m u²/2 is exact to round-off
#: (the next terms are O(u³) relative to O(1)), and the recurrence on cn/sn would overflow.
_SMALL_U = 2.0**-28
#: Dekker's splitting constant 2^27 + 1 for float64.
_SPLIT = 134217729.0


# ----------------------------------------------------------------------------- error-free arithmetic


def _special():
    """``scipy.special``, imported on first use: importing it takes about 0.2 s, and only the exact
    rotor's bodies call these functions (a node or a script without them starts without it)."""
    from scipy import special

    return special


def two_sum(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``a + b = s + e`` exactly, ``s = fl(a + b)`` (Knuth's TwoSum; any magnitudes)."""
    s = a + b
    bb = s - a
    return s, (a - (s - bb)) + (b - bb)


def two_product(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``a · b = p + e`` exactly, ``p = fl(a · b)`` (Dekker's TwoProduct by splitting).

    Exact for |a|, |b| below ~1e150 and products above the underflow range (the callers pass
    values scaled to order one). numpy does not contract ``a * b + c`` into an FMA, so the
    splitting is exact on every CPU.
    """
    p = a * b
    t = _SPLIT * a
    a_hi = t - (t - a)
    a_lo = a - a_hi
    t = _SPLIT * b
    b_hi = t - (t - b)
    b_lo = b - b_hi
    return p, ((a_hi * b_hi - p) + a_hi * b_lo + a_lo * b_hi) + a_lo * b_lo


def difference_of_products(c: np.ndarray, x: np.ndarray, d: np.ndarray, y: np.ndarray) -> np.ndarray:
    """``c x² − d y²`` to a few ulp of itself plus a few ulp² of the terms, however they cancel.

    The squares and their products with the coefficients are formed exactly as double-doubles
    (:func:`two_product`), subtracted with :func:`two_sum` and rounded once at the end. ``c``,
    ``d`` are taken as exact (they are the caller's model constants).
    """
    x2, x2_err = two_product(x, x)
    y2, y2_err = two_product(y, y)
    cx, cx_err = two_product(c, x2)
    dy, dy_err = two_product(d, y2)
    s, s_err = two_sum(cx, -dy)
    return s + (s_err + ((cx_err - dy_err) + (c * x2_err - d * y2_err)))


# ----------------------------------------------------------------------------- K and the Jacobi functions


def complete_k(m_c: np.ndarray) -> np.ndarray:
    """Complete elliptic integral of the first kind K(m), from ``m_c = 1 − m`` ∈ (0, 1].

    ``scipy.special.ellipkm1``, which takes m_c itself and so is accurate to a few ulp as
    m_c → 0 (where K ≈ ln(4/√m_c)).
    """
    return _special().ellipkm1(m_c)


def jacobi_reduced(r: np.ndarray, m_c: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """sn, cn, dn of ``r`` ∈ [−K, K] (so cn ≥ 0) and parameter ``m = 1 − m_c``, m_c ∈ [0, 1].

    Bulirsch's algorithm (the descending Landen/Gauss transformation applied to the ratio
    cn/sn, as in Numerical Recipes' ``sncndn``), run on |r| so that every term of the backward
    recurrence is non-negative: nothing cancels, and sn, cn, dn come out with a relative error
    of a few ulp even where cn and dn are tiny (r near K, m near 1). m_c = 0 is the separatrix
    limit sn = tanh r, cn = dn = sech r.

    Parameters
    ----------
    r : ndarray
        Arguments, within [−K(m), K(m)] (not checked; outside it cn is returned as |cn|).
    m_c : ndarray
        Complementary parameters 1 − m, broadcast with ``r``.

    Returns
    -------
    sn, cn, dn : ndarray
        The Jacobi functions, shape of the broadcast inputs.
    """
    r, m_c = np.broadcast_arrays(np.asarray(r, dtype=float), np.asarray(m_c, dtype=float))
    x = np.abs(r)
    # Forward: the AGM of (1, √m_c), keeping a_i and √(m_c,i) of every step.
    a = np.ones_like(x)
    b2 = np.where(m_c > 0.0, m_c, 1.0)  # m_c = 0 lanes are replaced by the tanh/sech limit below
    a_steps, b_steps = [], []
    for _ in range(_AGM_MAX_STEPS):
        b = np.sqrt(b2)
        a_steps.append(a)
        b_steps.append(b)
        mean = 0.5 * (a + b)
        if np.all(np.abs(a - b) <= _AGM_RTOL * a):
            break
        b2 = b * a
        a = mean
    else:  # pragma: no cover - quadratic convergence makes this unreachable for m_c ∈ (0, 1]
        raise RuntimeError(f"Landen recurrence did not converge for m_c = {m_c!r}.")
    # Backward: from cot(x·AGM) down to cn/sn at parameter m.
    phase = x * mean  # ∈ [0, π/2] for x ∈ [0, K]
    small = x < _SMALL_U
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        ratio = np.cos(phase) / np.where(small, 1.0, np.sin(phase))  # cot of the phase
        c = mean * ratio
        dn = np.ones_like(x)
        for a_i, b_i in zip(reversed(a_steps), reversed(b_steps)):
            ratio = ratio * c
            c = c * dn
            dn = (b_i + ratio) / (a_i + ratio)
            ratio = c / a_i
        sn = 1.0 / np.sqrt(c * c + 1.0)
        cn = c * sn
    m = 1.0 - m_c
    sn = np.where(small, x, sn)
    cn = np.where(small, 1.0 - 0.5 * x * x, cn)
    dn = np.where(small, 1.0 - 0.5 * m * x * x, dn)
    separatrix = m_c == 0.0
    if separatrix.any():
        sech = 1.0 / np.cosh(x)
        sn = np.where(separatrix, np.tanh(x), sn)
        cn = np.where(separatrix, sech, cn)
        dn = np.where(separatrix, sech, dn)
    return np.copysign(sn, r), cn, dn


def reduce_phase(u: np.ndarray, two_k: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``u = j · 2K + r`` with j an integer (as float) and r ∈ [−K, K]; returns (j, r).

    Then sn(u) = (−1)^j sn(r), cn(u) = (−1)^j cn(r), dn(u) = dn(r), am(u) = jπ + am(r).
    ``two_k = inf`` (the separatrix) gives j = 0, r = u.
    """
    j = np.round(u / two_k)
    return j, u - np.where(j == 0.0, 0.0, j * two_k)


def jacobi(u: np.ndarray, m_c: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """sn(u | m), cn(u | m), dn(u | m) for any real u, from ``m_c = 1 − m`` ∈ [0, 1].

    The argument is reduced by :func:`reduce_phase` (absolute error ~ ulp(u), the conditioning
    of the problem) and evaluated by :func:`jacobi_reduced`.
    """
    u, m_c = np.broadcast_arrays(np.asarray(u, dtype=float), np.asarray(m_c, dtype=float))
    with np.errstate(divide="ignore"):
        two_k = 2.0 * np.where(m_c > 0.0, complete_k(np.where(m_c > 0.0, m_c, 1.0)), np.inf)
    j, r = reduce_phase(u, two_k)
    sn, cn, dn = jacobi_reduced(r, m_c)
    parity = 1.0 - 2.0 * np.mod(j, 2.0)
    return parity * sn, parity * cn, dn


# ----------------------------------------------------------------------------- incomplete integrals


def elliptic_f(sin_beta: np.ndarray, cos_beta: np.ndarray, delta: np.ndarray) -> np.ndarray:
    """F(β | m) for β ∈ [−π/2, π/2], from sin β, cos β ≥ 0 and Δ = √(1 − m sin²β).

    ``F = sin β · R_F(cos²β, Δ², 1)`` (Carlson; DLMF 19.25.5): relative accuracy of a few ulp
    given the three inputs to full relative precision, however close β is to π/2 and m to 1.
    """
    s, c, d = sin_beta, cos_beta, delta
    return s * _special().elliprf(c * c, d * d, 1.0)


def elliptic_f_angle(beta: np.ndarray, m_c: np.ndarray) -> np.ndarray:
    """F(β | m) for any real β, from ``m_c = 1 − m`` (F(β + jπ) = F(β) + 2jK)."""
    j = np.round(beta / np.pi)
    beta_r = beta - j * np.pi  # in [−π/2, π/2]
    s, c = np.sin(beta_r), np.cos(beta_r)
    f = elliptic_f(s, c, np.sqrt(c * c + m_c * s * s))  # Δ² = 1 − m sin²β without cancellation
    return np.where(j == 0.0, f, f + 2.0 * j * complete_k(m_c))


def third_kind_minus_f(sin_beta: np.ndarray, cos_beta: np.ndarray, delta: np.ndarray, n: np.ndarray
                       ) -> np.ndarray:
    """Π(n; β | m) − F(β | m) for β ∈ [−π/2, π/2] and n < 1, from sin β, cos β ≥ 0, Δ.

    ``Π − F = (n/3) sin³β R_J(cos²β, Δ², 1, 1 − n sin²β)`` (DLMF 19.25.14 minus 19.25.5), with
    no cancellation for n ≤ 0 (all arguments positive).
    """
    s, c, d = sin_beta, cos_beta, delta
    return (n / 3.0) * s**3 * _special().elliprj(c * c, d * d, 1.0, 1.0 - n * s * s)


def third_kind_minus_f_complete(n: np.ndarray, m_c: np.ndarray) -> np.ndarray:
    """Π(n | m) − K(m) = (n/3) R_J(0, m_c, 1, 1 − n), the value of :func:`third_kind_minus_f` at π/2."""
    return (n / 3.0) * _special().elliprj(0.0, m_c, 1.0, 1.0 - n)
