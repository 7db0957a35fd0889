"""Exact rigid-body motions, the references that integrator tests and benchmarks compare with.

Every function here is a closed form (or, for the precession angle of the asymmetric top, a
closed form plus a one-dimensional quadrature to ~1e-13), vectorised over a 1-D array of
times ``t`` of shape (T,) in seconds; outputs have leading dimension T. Conventions are the
package's: quaternions are (w, x, y, z), Hamilton product, ``q_WB`` maps body to world
(``v_W = q_WB ⊗ (0, v_B) ⊗ q_WB*``); the body frame B is the principal frame, so the inertia
is the diagonal ``(I1, I2, I3)`` in kg·m²; angular velocities ``w_B`` are in body axes (rad/s);
torque-free motion obeys ``I dw_B/dt = −w_B × (I w_B)`` and ``dq_WB/dt = ½ q_WB ⊗ (0, w_B)``.
Returned quaternions are continuous in t and equal ``+q_WB0`` at t = 0, so they are the same
sign-branch as an integrated quaternion, not only the same rotation. Inputs are validated
here, at the edge; a non-unit ``q_WB0`` is an error, not silently normalised.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import special

from ..core import elliptic
from ..core.quaternion import (
    quat_conjugate,
    quat_from_matrix,
    quat_from_rotation_vector,
    quat_multiply,
    quat_rotate,
)

__all__ = [
    "symmetric_top",
    "symmetric_top_flow",
    "asymmetric_top_body_rates",
    "asymmetric_top",
    "intermediate_axis_flip_period",
    "constant_principal_torque",
    "projectile",
    "box_body_fixed_force",
]

EQUAL_MOMENTS_RTOL = 1e-12  # two principal moments this close count as equal
SEPARATRIX_RTOL = 1e-14  # |L² − 2E·I2| ≤ this · L² counts as the separatrix
UNIT_QUAT_ATOL = 1e-12  # allowed | |q_WB0| − 1 |
TRIANGLE_RTOL = 1e-12  # slack in I_max ≤ I_j + I_k (a thin plate is exactly at equality)
AXIAL_TORQUE_RTOL = 1e-12  # off-axis torque allowed, relative to |r_B|·|F_B|
QUAD_EPS = 1e-13  # relative tolerance of the precession-angle quadrature
_EPS = np.finfo(float).eps / 2.0  # unit round-off, 2^-53


# ----------------------------------------------------------------------------- validation


def _array(name: str, value: object, shape: tuple[int, ...], shape_text: str) -> np.ndarray:
    """``value`` as a finite float array of exactly ``shape``, else a ValueError naming it."""
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"Expected `{name}` to be a real array of shape {shape_text}, got {value!r}.") from exc
    if arr.shape != shape:
        raise ValueError(f"Expected `{name}` to have shape {shape_text}, got {arr.shape}.")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"Expected `{name}` to be finite, got {arr}.")
    return arr


def _vector3(name: str, value: object) -> np.ndarray:
    return _array(name, value, (3,), "(3,)")


def _scalar(name: str, value: object) -> float:
    return float(_array(name, value, (), "() (a scalar)"))


def _positive_scalar(name: str, value: object, unit: str) -> float:
    x = _scalar(name, value)
    if not x > 0.0:
        raise ValueError(f"Expected `{name}` to be positive ({unit}), got {x}.")
    return x


def _times(t: object) -> np.ndarray:
    try:
        arr = np.asarray(t, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"Expected `t` to be a real array of shape (T,), got {t!r}.") from exc
    if arr.ndim != 1:
        raise ValueError(f"Expected `t` to have shape (T,), got {arr.shape}.")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"Expected `t` to be finite (s), got non-finite values in {arr}.")
    return arr


def _inertia(inertia: object) -> np.ndarray:
    I = _vector3("inertia", inertia)
    if not np.all(I > 0.0):
        raise ValueError(f"Expected `inertia` to hold three positive principal moments (kg*m^2), got {I}.")
    total = np.sum(I)
    if np.any(I > (total - I) * (1.0 + TRIANGLE_RTOL)):
        raise ValueError(
            "Expected `inertia` to satisfy the triangle inequality I_i <= I_j + I_k of a real body, "
            f"got {I}."
        )
    return I


def _unit_quaternion(name: str, value: object) -> np.ndarray:
    q = _array(name, value, (4,), "(4,) (w, x, y, z)")
    norm = np.linalg.norm(q)
    if abs(norm - 1.0) > UNIT_QUAT_ATOL:
        raise ValueError(
            f"Expected `{name}` to be a unit quaternion (w, x, y, z) (| |q| - 1 | <= {UNIT_QUAT_ATOL}), "
            f"got {q} with norm {norm!r}."
        )
    return q


def _equal_moment_pairs(I: np.ndarray) -> list[tuple[int, int]]:
    pairs = []
    for j, k in ((0, 1), (0, 2), (1, 2)):
        if abs(I[j] - I[k]) <= EQUAL_MOMENTS_RTOL * max(I[j], I[k]):
            pairs.append((j, k))
    return pairs


# ----------------------------------------------------------------------------- small helpers


def _axis_quat(angle: np.ndarray, axis: int) -> np.ndarray:
    """Quaternions (w, x, y, z) of rotations by ``angle`` (rad, shape (T,)) about a basis axis."""
    angle = np.asarray(angle, dtype=float)
    q = np.zeros(angle.shape + (4,))
    q[..., 0] = np.cos(0.5 * angle)
    q[..., 1 + axis] = np.sin(0.5 * angle)
    return q


def _uniform_spin(q_WB0: np.ndarray, w_B: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Constant body rate: ``q(t) = q0 ⊗ exp(t w_B)``."""
    q = quat_multiply(q_WB0, quat_from_rotation_vector(t[:, None] * w_B))
    return q, np.broadcast_to(w_B, (t.size, 3)).copy()


# ----------------------------------------------------------------------------- symmetric top


def symmetric_top(
    inertia: np.ndarray, w_B0: np.ndarray, q_WB0: np.ndarray, t: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Torque-free axisymmetric body: exact orientation and body rates.

    Two principal moments must be equal (any two; within a relative 1e-12). With ``e_s`` the
    symmetry axis, ``I_s`` its moment, ``I_t`` the transverse moment, ``ω_s`` the (constant)
    spin rate and ``L_W = R0 I w_B0`` the constant world angular momentum,

        R_WB(t) = exp(t [L_W]× / I_t) · R_WB0 · exp(t λ [e_s]×),   λ = ω_s (1 − I_s / I_t),
        w_B(t)  = exp(−t λ [e_s]×) w_B0,

    i.e. the body axis cones about L at ``|L|/I_t`` while the body rate vector turns about
    ``e_s`` at −λ in body axes (the body-frame precession rate (I_s − I_t) ω_s / I_t). If all
    three moments are equal (a sphere) λ = 0 and this is a uniform rotation.

    Parameters
    ----------
    inertia : array-like, shape (3,)
        Principal moments (I1, I2, I3), kg·m², two of them equal.
    w_B0 : array-like, shape (3,)
        Initial angular velocity in body (principal) axes, rad/s.
    q_WB0 : array-like, shape (4,)
        Initial body-to-world unit quaternion, (w, x, y, z).
    t : array-like, shape (T,)
        Times, s (any order, any sign; t = 0 is the initial state).

    Returns
    -------
    q_WB : ndarray, shape (T, 4)
        Body-to-world quaternions (w, x, y, z), continuous in t, ``+q_WB0`` at t = 0.
    w_B : ndarray, shape (T, 3)
        Angular velocities in body axes, rad/s.

    Raises
    ------
    ValueError
        If no two moments are equal within a relative 1e-12, or an input is malformed.
    """
    I = _inertia(inertia)
    w0 = _vector3("w_B0", w_B0)
    q0 = _unit_quaternion("q_WB0", q_WB0)
    t = _times(t)
    pairs = _equal_moment_pairs(I)
    if not pairs:
        raise ValueError(
            f"symmetric_top needs two equal principal moments (relative {EQUAL_MOMENTS_RTOL}) in `inertia`, "
            f"got {I}; use asymmetric_top for a body with three distinct moments."
        )
    j, k = pairs[0]
    s = 3 - j - k  # the remaining axis is the symmetry axis
    I_t = 0.5 * (I[j] + I[k])
    I_s = I[s]
    e_s = np.zeros(3)
    e_s[s] = 1.0
    q_WB, L_B = symmetric_top_flow(q0, I * w0, 1.0 / I_t, e_s, 1.0 / I_s - 1.0 / I_t, t)
    return q_WB, L_B / I


def symmetric_top_flow(
    q_WB0: np.ndarray, L_B0: np.ndarray, inv_inertia_t: np.ndarray, e_s_B: np.ndarray, c_s: np.ndarray,
    t: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """The exact flow of ``H = |L|²/(2 I_t) + ½ c_s (L·e_s)²``, broadcast over any leading shape.

    With ``c_s = 1/I_s − 1/I_t`` this is the torque-free symmetric top of :func:`symmetric_top`
    (symmetry axis e_s, moment I_s, transverse moment I_t); the two terms commute (|L|² is a
    Casimir), and each is an exact rotation::

        q_WB(t) = q_WB0 ⊗ exp(t L_B0 / I_t) ⊗ exp(t λ e_s),     λ = c_s (L_B0·e_s) = ω_s (1 − I_s/I_t),
        L_B(t)  = exp(−t λ e_s) L_B0,

    where ``q_WB0 ⊗ exp(t L_B0 / I_t) = exp(t L_W / I_t) ⊗ q_WB0``: the body cones about the
    constant L_W at |L|/I_t. With ``inv_inertia_t = 0`` it is the flow of ``½ c_s L_s²`` alone, a
    rotation about e_s at the rate c_s L_s (the remainder of a splitting, integrators.py).
    Vectorised and unvalidated: the callers validate.

    Parameters
    ----------
    q_WB0 : ndarray, shape (..., 4)
        Body-to-world unit quaternions (w, x, y, z).
    L_B0 : ndarray, shape (..., 3)
        Angular momentum in body axes, kg·m²/s.
    inv_inertia_t : ndarray, shape (...)
        1/I_t, 1/(kg·m²); 0 drops the precession about L.
    e_s_B : ndarray, shape (..., 3)
        Unit symmetry axis, body axes.
    c_s : ndarray, shape (...)
        1/I_s − 1/I_t, 1/(kg·m²).
    t : ndarray, shape (...)
        Times, s.

    Returns
    -------
    q_WB : ndarray, shape (..., 4)
    L_B : ndarray, shape (..., 3)
    """
    L_s = np.sum(L_B0 * e_s_B, axis=-1)
    q_precession = quat_from_rotation_vector(np.expand_dims(t * inv_inertia_t, -1) * L_B0)
    q_spin = quat_from_rotation_vector(np.expand_dims(t * c_s * L_s, -1) * e_s_B)
    return quat_multiply(quat_multiply(q_WB0, q_precession), q_spin), quat_rotate(quat_conjugate(q_spin), L_B0)


# ----------------------------------------------------------------------------- asymmetric top


@dataclass(frozen=True)
class _EulerPoinsot:
    """Elliptic-function solution of a torque-free body, in sorted principal axes S.

    ``w_S = P w_B`` with P a signed permutation, det P = +1, making I_S = (I1 < I2 < I3).
    ``case`` 1 (L² > 2E I2, polhode about axis 3): w_S = (σ a1 cn u, a2 sn u, σ a3 dn u);
    ``case`` 2 (L² < 2E I2, polhode about axis 1): w_S = (σ a1 dn u, a2 sn u, σ a3 cn u);
    u = u0 + ν t, parameter m = k².
    """

    P: np.ndarray  # (3, 3) signed permutation, w_S = P w_B
    I_S: np.ndarray  # (3,) sorted moments, kg·m²
    case: int  # 1 or 2
    sigma: float  # ±1
    amp: np.ndarray  # (3,) amplitudes a1, a2, a3, rad/s
    nu: float  # du/dt, rad/s
    m: float  # elliptic parameter k², in [0, 1)
    m_c: float  # 1 − m, to full relative precision (L² − 2E·I2 by error-free products)
    j0: float  # initial phase u0 = 2K j0 + r0, r0 ∈ [−K, K]
    r0: float
    K: float  # K(m), the quarter period in u
    qp: float  # q/p, the ratio of the (b, a) amplitudes of I ω (see asymmetric_top)
    L2: float  # |L|², (kg·m²/s)²
    transverse_zero: bool  # pure spin about the axis the polhode encircles


def _euler_poinsot(I: np.ndarray, w0: np.ndarray, caller: str) -> _EulerPoinsot | None:
    """Parameters of the Jacobi-elliptic solution; None for w_B0 = 0 (no motion)."""
    if _equal_moment_pairs(I):
        raise ValueError(
            f"{caller} needs three distinct principal moments in `inertia` (relative {EQUAL_MOMENTS_RTOL}), "
            f"got {I}; use symmetric_top for a body with two equal moments."
        )
    order = np.argsort(I)
    P = np.zeros((3, 3))
    P[np.arange(3), order] = 1.0
    if np.linalg.det(P) < 0.0:
        P[0] *= -1.0  # a proper rotation keeps I ω' = −ω × Iω in the same form
    I1, I2, I3 = I[order]
    w1, w2, w3 = P @ w0
    L2 = (I1 * w1) ** 2 + (I2 * w2) ** 2 + (I3 * w3) ** 2
    if L2 == 0.0:
        return None
    d21, d31, d32 = I2 - I1, I3 - I1, I3 - I2
    # The three combinations of energy and momentum; D1, D3 are sums of squares, and D2,
    # the difference that vanishes on the separatrix, is formed with error-free products so
    # that m_c below has full relative precision however close to the separatrix w_B0 is.
    D1 = I2 * d21 * w2**2 + I3 * d31 * w3**2  # L² − 2E·I1 ≥ 0
    D3 = I1 * d31 * w1**2 + I2 * d32 * w2**2  # 2E·I3 − L² ≥ 0
    D2 = float(elliptic.difference_of_products(I3 * d32, w3, I1 * d21, w1))  # L² − 2E·I2
    if abs(D2) <= SEPARATRIX_RTOL * L2:
        raise ValueError(
            f"{caller}: the motion is on the separatrix, L^2 = 2E*I2 within a relative {SEPARATRIX_RTOL} "
            f"(inertia={I}, w_B0={w0}); the elliptic solution degenerates (period -> infinity) there."
        )
    if D2 > 0.0:  # Landau & Lifshitz §37, (37.10): polhode about the largest-moment axis
        case, sigma = 1, float(np.sign(w3)) or 1.0
        amp = np.sqrt([D3 / (I1 * d31), D3 / (I2 * d32), D1 / (I3 * d31)])
        nu = np.sqrt(d32 * D1 / (I1 * I2 * I3))
        m = d21 * D3 / (d32 * D1)
        m_c = d31 * D2 / (d32 * D1)
        qp = np.sqrt(I2 * d31 / (I1 * d32))  # (I2 a2) / (I1 a1)
        transverse_zero = D3 == 0.0
    else:  # the same with axes 1 and 3 exchanged: polhode about the smallest-moment axis
        case, sigma = 2, float(np.sign(w1)) or 1.0
        amp = np.sqrt([D3 / (I1 * d31), D1 / (I2 * d21), D1 / (I3 * d31)])
        nu = np.sqrt(d21 * D3 / (I1 * I2 * I3))
        m = d32 * D1 / (d21 * D3)
        m_c = -d31 * D2 / (d21 * D3)
        qp = np.sqrt(I2 * d31 / (I3 * d21))  # (I2 a2) / (I3 a3)
        transverse_zero = D1 == 0.0
    K = float(elliptic.complete_k(m_c))
    j0, r0 = 0.0, 0.0
    if not transverse_zero:
        # sn u0, cn u0, dn u0 read off w_B0, each to full relative precision (the polhode is
        # w_S = (σ a1 cn, a2 sn, σ a3 dn) in case 1, (σ a1 dn, a2 sn, σ a3 cn) in case 2).
        r_w = np.array([w1, w2, w3]) / amp * np.array([sigma, 1.0, sigma])
        sn0, cn0, dn0 = (r_w[1], r_w[0], abs(r_w[2])) if case == 1 else (r_w[1], r_w[2], abs(r_w[0]))
        j0 = 1.0 if cn0 < 0.0 else 0.0  # u0 = 2K j0 + r0 with cn(r0) ≥ 0
        r0 = float(elliptic.elliptic_f(sn0 if cn0 >= 0.0 else -sn0, abs(cn0), dn0))
    return _EulerPoinsot(
        P, np.array([I1, I2, I3]), case, sigma, amp, float(nu), float(m), float(m_c), j0, r0, K, float(qp), L2,
        transverse_zero,
    )


@dataclass(frozen=True)
class _Phase:
    """Jacobi functions at u = u0 + ν t, reduced: u = 2K j + r, r ∈ [−K, K]."""

    j: np.ndarray  # half-periods, float-valued integers
    r: np.ndarray  # reduced phase
    sn: np.ndarray  # sn(u)
    cn: np.ndarray  # cn(u)
    dn: np.ndarray  # dn(u)
    sn_r: np.ndarray  # sn(r)
    cn_r: np.ndarray  # cn(r) ≥ 0


def _phase(ep: _EulerPoinsot, t: np.ndarray) -> _Phase:
    dj, r = elliptic.reduce_phase(ep.r0 + ep.nu * t, 2.0 * ep.K)  # relative to u0: no 2K j0 round trip
    j = ep.j0 + dj
    sn_r, cn_r, dn = elliptic.jacobi_reduced(r, ep.m_c)
    parity = 1.0 - 2.0 * np.mod(j, 2.0)  # sn, cn change sign every 2K; dn does not
    return _Phase(j, r, parity * sn_r, parity * cn_r, dn, sn_r, cn_r)


def _rates_S(ep: _EulerPoinsot, ph: _Phase) -> np.ndarray:
    a1, a2, a3 = ep.amp
    s = ep.sigma
    if ep.case == 1:
        return np.stack((s * a1 * ph.cn, a2 * ph.sn, s * a3 * ph.dn), axis=-1)
    return np.stack((s * a1 * ph.dn, a2 * ph.sn, s * a3 * ph.cn), axis=-1)


def asymmetric_top_body_rates(inertia: np.ndarray, w_B0: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Body angular velocity of a torque-free body with three distinct moments (Jacobi functions).

    Landau & Lifshitz, *Mechanics*, §37. In sorted axes (I1 < I2 < I3), with
    E = ½ Σ I ω², L² = Σ I² ω², u = ν t + u0 and parameter m = k²:

    * L² > 2E·I2 (polhode about the largest-moment axis)::

        ω1 = σ √((2E I3 − L²)/(I1 (I3 − I1))) cn u
        ω2 =   √((2E I3 − L²)/(I2 (I3 − I2))) sn u
        ω3 = σ √((L² − 2E I1)/(I3 (I3 − I1))) dn u
        ν  = √((I3 − I2)(L² − 2E I1)/(I1 I2 I3)),  m = (I2 − I1)(2E I3 − L²)/((I3 − I2)(L² − 2E I1))

    * L² < 2E·I2: the same with the indices 1 and 3 exchanged (ω1 ∝ dn, ω3 ∝ cn).

    σ = ±1 is the (constant) sign of the encircled-axis rate; the phase u0 comes from the
    initial condition: sn u0, cn u0, dn u0 are read off w_B0 and u0 = F(am u0 | m) by
    Carlson's R_F from them. sn, cn, dn and F are evaluated from m_c = 1 − m, itself computed
    with error-free products (L² − 2E·I2 cancels near the separatrix), by Bulirsch's Landen
    recurrence (:mod:`~rigid_body_sim.core.elliptic`), which keeps cn and dn to full relative
    precision where they are small; not by ``scipy.special.ellipj``/``ellipkinc``, which take
    only m and fail near the separatrix (scipy issue #8480).

    Any ordering of the moments is allowed: the axes are sorted by a signed permutation with
    det +1, a proper rotation, so Euler's equations keep their form. A pure spin about the
    largest or smallest axis (zero amplitudes) is exact; ``w_B0 = 0`` gives zeros.

    Parameters
    ----------
    inertia : array-like, shape (3,)
        Principal moments (I1, I2, I3), kg·m², pairwise distinct, any order.
    w_B0 : array-like, shape (3,)
        Initial angular velocity in body (principal) axes, rad/s.
    t : array-like, shape (T,)
        Times, s (any order, any sign).

    Returns
    -------
    w_B : ndarray, shape (T, 3)
        Angular velocities in body axes, rad/s, in the order of ``inertia``.

    Raises
    ------
    ValueError
        On the separatrix (|L² − 2E·I2| ≤ 1e-14·L², e.g. a pure spin about the intermediate
        axis), if two moments are equal (use :func:`symmetric_top`), or on malformed input.
    """
    I = _inertia(inertia)
    w0 = _vector3("w_B0", w_B0)
    t = _times(t)
    ep = _euler_poinsot(I, w0, "asymmetric_top_body_rates")
    if ep is None:
        return np.zeros((t.size, 3))
    return _rates_S(ep, _phase(ep, t)) @ ep.P  # w_B = Pᵀ w_S, row-wise


def intermediate_axis_flip_period(inertia: np.ndarray, w_B0: np.ndarray) -> float:
    """Time between successive sign changes of the intermediate-axis rate, ``2 K(m) / ν`` (s).

    In both elliptic cases the intermediate-axis rate is ``a2 sn(ν t + u0)``, which changes
    sign every half period 2K(m) of u (see :func:`asymmetric_top_body_rates`). This is the
    "tennis racket" / Dzhanibekov flip time; it grows like ln(1/distance) near the separatrix.
    For a pure spin about the largest or smallest axis the rate is identically zero and the
    value returned is the small-wobble limit π/ν.

    Parameters
    ----------
    inertia : array-like, shape (3,)
        Principal moments, kg·m², pairwise distinct, any order.
    w_B0 : array-like, shape (3,)
        Initial angular velocity in body axes, rad/s, not zero.

    Returns
    -------
    float
        Seconds. For inertia (1, 2, 3) and w_B0 (1e-3, 1, 1e-3) it is 27.53 s.
    """
    I = _inertia(inertia)
    w0 = _vector3("w_B0", w_B0)
    ep = _euler_poinsot(I, w0, "intermediate_axis_flip_period")
    if ep is None:
        raise ValueError(f"Expected `w_B0` to be non-zero (rad/s), got {w0}: a body at rest never flips.")
    return float(2.0 * ep.K / ep.nu)


def _precession_rate(ep: _EulerPoinsot, g: np.ndarray, I_ab: np.ndarray, u: np.ndarray) -> np.ndarray:
    """dφ/du · ν/|L| = (g_a f_a² + g_b f_b²) / (I_a g_a f_a² + I_b g_b f_b²), even and 2K-periodic in u.

    g_i = 1/|I_c − I_i| and (f_a, f_b) = (cn u, sn u) in case 1, (sn u, cn u) in case 2: φ' =
    |L| (I_a ω_a² + I_b ω_b²) / (I_a² ω_a² + I_b² ω_b²) on the polhode. Bounded between
    1/max(I_a, I_b) and 1/min(I_a, I_b), smooth in u on the scale of one unit: no endpoint
    singularity near the separatrix, unlike the same integral in β = am u.
    """
    sn, cn, _ = elliptic.jacobi_reduced(u, ep.m_c)
    fa2, fb2 = (cn * cn, sn * sn) if ep.case == 1 else (sn * sn, cn * cn)
    return (g[0] * fa2 + g[1] * fb2) / (I_ab[0] * g[0] * fa2 + I_ab[1] * g[1] * fb2)


def _precession_integral(ep: _EulerPoinsot, g: np.ndarray, I_ab: np.ndarray, r: np.ndarray
                         ) -> tuple[np.ndarray, float]:
    """H(r) = ∫₀^r (dφ/du · ν/|L|) du for r ∈ [−K, K] (shape (N,)), and H(2K) = 2 H(K).

    The integrand is even, so H is odd: the |r| are sorted and the pieces between successive
    knots 0 ≤ |r_i| ≤ K are integrated by composite 16-point Gauss–Legendre, every panel at
    most ``width`` long, halving ``width`` until two successive results agree to QUAD_EPS
    (relative to H(K)). One vectorised evaluation per level, whatever N.
    """
    x_gl, w_gl = np.polynomial.legendre.leggauss(16)
    knots = np.unique(np.concatenate(([0.0], np.abs(r), [ep.K])))
    lengths = np.diff(knots)
    previous = None
    width = 0.5
    for _ in range(12):
        panels = np.maximum(1, np.ceil(lengths / width)).astype(int)
        piece = np.repeat(np.arange(lengths.size), panels)
        index = np.arange(piece.size) - np.repeat(np.cumsum(panels) - panels, panels)
        panel_len = lengths[piece] / panels[piece]
        start = knots[piece] + index * panel_len
        u = start[:, None] + 0.5 * panel_len[:, None] * (x_gl + 1.0)
        values = _precession_rate(ep, g, I_ab, u) @ w_gl * (0.5 * panel_len)
        pieces = np.bincount(piece, weights=values, minlength=lengths.size)
        cumulative = np.concatenate(([0.0], np.cumsum(pieces)))
        if previous is not None and np.max(np.abs(cumulative - previous)) <= QUAD_EPS * cumulative[-1]:
            break
        previous = cumulative
        width *= 0.5
    else:  # pragma: no cover - 16-point panels of 0.5/2^11 in u resolve any body
        raise RuntimeError(f"precession quadrature did not converge (inertia {ep.I_S}, m_c {ep.m_c}).")
    H = np.sign(r) * np.interp(np.abs(r), knots, cumulative)  # exact at the knots
    return H, 2.0 * cumulative[-1]


def asymmetric_top(
    inertia: np.ndarray, w_B0: np.ndarray, q_WB0: np.ndarray, t: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Torque-free body with three distinct moments: exact body rates and orientation.

    The body rates are those of :func:`asymmetric_top_body_rates`. For the orientation,
    relabel the sorted axes cyclically (a proper rotation) as (a, b, c), where c is the axis
    the polhode encircles (the largest-moment axis when L² > 2E·I2, the smallest when
    L² < 2E·I2), so ``I_a ω_a`` and ``I_b ω_b`` never vanish together. Take z–x–z Euler angles
    (φ, θ, ψ) of those body axes relative to a fixed frame Λ whose z axis is along the
    constant angular momentum L (Landau & Lifshitz §37)::

        L_(a,b,c) = |L| (sin θ sin ψ, sin θ cos ψ, cos θ)      → θ, ψ from w_B(t)
        φ' = |L| (I_a ω_a² + I_b ω_b²) / (I_a² ω_a² + I_b² ω_b²)   > 0

    φ is obtained by quadrature in u = u0 + ν t (composite Gauss–Legendre refined to a
    relative 1e-13), in which dφ/du is bounded, smooth and 2K-periodic even on the edge of the
    separatrix (in β = am u it would peak like 1/dn there); only the fractional period is
    integrated, piecewise between the sorted output phases, so the cost does not grow with t.
    This is independent of :func:`~rigid_body_sim.core.free_rotor.exact_rotor`, which gets the
    same angle from Legendre's integral of the third kind. Then

        R_WB(t) = C · Rz(φ(t) − φ(0)) · Rx(θ(t)) · Rz(ψ(t)) · Q,

    with Q the constant proper rotation from body to (a, b, c) components and C fixed by
    ``R_WB(0) = R(q_WB0)`` (C maps Λ's z axis onto L_W). ψ is taken continuous in t, so the
    quaternion is too. A pure spin about the largest or smallest axis is returned as the
    uniform rotation ``q_WB0 ⊗ exp(t w_B0)``.

    Parameters
    ----------
    inertia : array-like, shape (3,)
        Principal moments (I1, I2, I3), kg·m², pairwise distinct, any order.
    w_B0 : array-like, shape (3,)
        Initial angular velocity in body (principal) axes, rad/s.
    q_WB0 : array-like, shape (4,)
        Initial body-to-world unit quaternion, (w, x, y, z).
    t : array-like, shape (T,)
        Times, s (any order, any sign).

    Returns
    -------
    q_WB : ndarray, shape (T, 4)
        Body-to-world quaternions (w, x, y, z), continuous in t, ``+q_WB0`` at t = 0.
    w_B : ndarray, shape (T, 3)
        Angular velocities in body axes, rad/s.

    Raises
    ------
    ValueError
        As :func:`asymmetric_top_body_rates`, and for a non-unit ``q_WB0``.
    """
    I = _inertia(inertia)
    w0 = _vector3("w_B0", w_B0)
    q0 = _unit_quaternion("q_WB0", q_WB0)
    t = _times(t)
    ep = _euler_poinsot(I, w0, "asymmetric_top")
    if ep is None or ep.transverse_zero:
        return _uniform_spin(q0, w0, t)

    # Evaluate at t = 0 as well, with the same formulas, to pin C.
    t_all = np.concatenate(([0.0], t))
    ph = _phase(ep, t_all)
    w_S = _rates_S(ep, ph)
    w_B = w_S @ ep.P

    I1, I2, I3 = ep.I_S
    if ep.case == 1:
        abc = (0, 1, 2)
        g = np.array([1.0 / (I3 - I1), 1.0 / (I3 - I2)])
    else:
        abc = (1, 2, 0)
        g = np.array([1.0 / (I2 - I1), 1.0 / (I3 - I1)])
    I_S = ep.I_S
    Q_cyc = np.eye(3)[list(abc)]
    Q = Q_cyc @ ep.P  # components in (a, b, c) = Q · components in B
    L_abc = (w_S * I_S)[:, list(abc)]
    M = np.sqrt(ep.L2)

    # θ ∈ (0, π): never 0 or π off the pure-spin case.
    theta = np.arctan2(np.hypot(L_abc[:, 0], L_abc[:, 1]), L_abc[:, 2])

    # χ = the branch of atan2(q sn u, p cn u) continuous in u: jπ + atan2(q sn r, p cn r), cn r ≥ 0.
    # Case 1: ψ = atan2(I1 ω1, I2 ω2) = atan2(σ p cn, q sn); case 2: ψ = atan2(I2 ω2, I3 ω3) = atan2(q sn, σ p cn).
    chi = np.pi * ph.j + np.arctan2(ep.qp * ph.sn_r, ph.cn_r)
    if ep.case == 1:
        psi = ep.sigma * (0.5 * np.pi - chi)
    else:
        psi = chi if ep.sigma > 0 else np.pi - chi

    # φ(t) − φ(0) = (|L|/ν) [H(u(t)) − H(u(0))], H(2K j + r) = j H(2K) + H(r).
    H_r, H_2K = _precession_integral(ep, g, I_S[list(abc[:2])], ph.r)
    H = ph.j * H_2K + H_r
    dphi = (M / ep.nu) * (H - H[0])

    q_Lambda = quat_multiply(quat_multiply(_axis_quat(dphi, 2), _axis_quat(theta, 0)), _axis_quat(psi, 2))
    q_Q = quat_from_matrix(Q)
    q_C = quat_multiply(quat_multiply(q0, quat_conjugate(q_Q)), quat_conjugate(q_Lambda[0]))
    q_WB = quat_multiply(quat_multiply(q_C, q_Lambda[1:]), q_Q)
    return q_WB, w_B[1:]


# ----------------------------------------------------------------------------- driven motions


def constant_principal_torque(
    inertia: np.ndarray, axis: int, w0: float, torque: float, q_WB0: np.ndarray, t: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Spin about a principal axis, driven by a constant torque about the same axis.

    With the angular velocity along principal axis k the gyroscopic term vanishes, so
    ``ω_k(t) = w0 + (τ/I_k) t`` and the rotation angle is ``w0 t + ½ (τ/I_k) t²``:
    ``q_WB(t) = q_WB0 ⊗ (cos(angle/2), sin(angle/2) e_k)``.

    Parameters
    ----------
    inertia : array-like, shape (3,)
        Principal moments (I1, I2, I3), kg·m².
    axis : int
        Body principal axis k: 0, 1 or 2.
    w0 : float
        Initial spin rate about axis k, rad/s (signed).
    torque : float
        Constant torque about body axis k, N·m (signed).
    q_WB0 : array-like, shape (4,)
        Initial body-to-world unit quaternion, (w, x, y, z).
    t : array-like, shape (T,)
        Times, s.

    Returns
    -------
    q_WB : ndarray, shape (T, 4)
        Body-to-world quaternions (w, x, y, z).
    w_B : ndarray, shape (T, 3)
        Angular velocities in body axes, rad/s (only component k is non-zero).
    """
    I = _inertia(inertia)
    if isinstance(axis, bool) or not isinstance(axis, (int, np.integer)) or axis not in (0, 1, 2):
        raise ValueError(f"Expected `axis` to be one of (0, 1, 2), got {axis!r}.")
    w0 = _scalar("w0", w0)
    torque = _scalar("torque", torque)
    q0 = _unit_quaternion("q_WB0", q_WB0)
    t = _times(t)
    alpha = torque / I[axis]  # rad/s²
    angle = w0 * t + 0.5 * alpha * t**2
    q_WB = quat_multiply(q0, _axis_quat(angle, int(axis)))
    w_B = np.zeros((t.size, 3))
    w_B[:, axis] = w0 + alpha * t
    return q_WB, w_B


def projectile(
    p0_W: np.ndarray, v0_W: np.ndarray, gravity_W: np.ndarray, t: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Centre of mass under uniform gravity: ``p = p0 + v0 t + ½ g t²``, ``v = v0 + g t``.

    Parameters
    ----------
    p0_W : array-like, shape (3,)
        Initial position, world axes, m.
    v0_W : array-like, shape (3,)
        Initial velocity, world axes, m/s.
    gravity_W : array-like, shape (3,)
        Gravitational acceleration, world axes, m/s² (e.g. (0, 0, −9.81)).
    t : array-like, shape (T,)
        Times, s.

    Returns
    -------
    p_W : ndarray, shape (T, 3)
        Positions, world axes, m.
    v_W : ndarray, shape (T, 3)
        Velocities, world axes, m/s.
    """
    p0 = _vector3("p0_W", p0_W)
    v0 = _vector3("v0_W", v0_W)
    g = _vector3("gravity_W", gravity_W)
    t = _times(t)[:, None]
    return p0 + v0 * t + 0.5 * g * t**2, v0 + g * t


def box_body_fixed_force(
    mass: float, inertia_axis: float, force_B: np.ndarray, point_B: np.ndarray, t: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """A body at rest at the origin, no gravity, pushed by a body-fixed force at a body-fixed point.

    The torque ``τ_B = r_B × F_B`` must lie along one principal axis k; then ω stays along
    e_k (no gyroscopic term) and, with ``e = sign(τ_k) e_k`` and ``α = |τ| / I_k``,

        θ(t) = ½ α t²  about e,        w_B = α t e,
        v_W(t) = (1/m) ∫₀ᵗ R(θ(s)) F_B ds
               = (1/m) [F_∥ t + √(π/α) (C(u) F_⊥ + S(u) e × F_⊥)],       u = t √(α/π),
        p_W(t) = (1/m) [½ F_∥ t² + (t √(π/α) C(u) − sin θ / α) F_⊥
                        + (t √(π/α) S(u) − (1 − cos θ) / α) e × F_⊥],

    where F_∥, F_⊥ are the parts of F_B along and across e, C and S the Fresnel integrals
    (``scipy.special.fresnel``), and the position uses ∫₀ᵘ C = u C(u) − sin(πu²/2)/π,
    ∫₀ᵘ S = u S(u) − (1 − cos(πu²/2))/π. For F_B = (0, 10, 0) N at r_B = (0.5, 0.3, 0) m
    this is v = (F/m) √(π/α) (−S(u), C(u), 0). A zero torque gives plain translation.

    Parameters
    ----------
    mass : float
        Mass, kg.
    inertia_axis : float
        Principal moment of inertia about the axis k of the torque, kg·m² (for a box of sides
        a × b about its third axis, ``m (a² + b²) / 12``). Unused when the torque is zero.
    force_B : array-like, shape (3,)
        Force, fixed in the body, body axes, N.
    point_B : array-like, shape (3,)
        Point of application relative to the centre of mass, body axes, m.
    t : array-like, shape (T,)
        Times, s.

    Returns
    -------
    q_WB : ndarray, shape (T, 4)
        Body-to-world quaternions (w, x, y, z); identity at t = 0.
    w_B : ndarray, shape (T, 3)
        Angular velocities, body axes, rad/s.
    v_W : ndarray, shape (T, 3)
        Centre-of-mass velocities, world axes, m/s.
    p_W : ndarray, shape (T, 3)
        Centre-of-mass positions, world axes, m (origin at t = 0).

    Raises
    ------
    ValueError
        If ``r_B × F_B`` has components off its largest axis beyond 1e-12·|r_B|·|F_B|, or on
        malformed input.
    """
    m = _positive_scalar("mass", mass, "kg")
    I_k = _positive_scalar("inertia_axis", inertia_axis, "kg*m^2")
    F = _vector3("force_B", force_B)
    r = _vector3("point_B", point_B)
    t = _times(t)
    tau = np.cross(r, F)  # N·m, body axes
    scale = np.linalg.norm(r) * np.linalg.norm(F)
    k = int(np.argmax(np.abs(tau)))
    off_axis = np.delete(tau, k)
    if np.any(np.abs(off_axis) > AXIAL_TORQUE_RTOL * scale):
        raise ValueError(
            "Expected the torque `point_B` x `force_B` to lie along one principal axis, "
            f"got {tau} N*m (force_B={F}, point_B={r})."
        )
    tc = t[:, None]
    if abs(tau[k]) <= AXIAL_TORQUE_RTOL * scale:  # no torque: plain translation
        q_WB = np.tile(np.array([1.0, 0.0, 0.0, 0.0]), (t.size, 1))
        return q_WB, np.zeros((t.size, 3)), F * tc / m, 0.5 * F * tc**2 / m
    e = np.zeros(3)
    e[k] = np.sign(tau[k])
    alpha = abs(tau[k]) / I_k  # rad/s²
    F_par = np.dot(F, e) * e
    F_perp = F - F_par
    F_side = np.cross(e, F_perp)
    theta = 0.5 * alpha * t**2
    u = t * np.sqrt(alpha / np.pi)
    S, C = special.fresnel(u)  # scipy returns (S, C)
    root = np.sqrt(np.pi / alpha)
    v_W = (F_par * tc + root * (C[:, None] * F_perp + S[:, None] * F_side)) / m
    cos_coef = t * root * C - np.sin(theta) / alpha
    sin_coef = t * root * S - 2.0 * np.sin(0.5 * theta) ** 2 / alpha
    p_W = (0.5 * F_par * tc**2 + cos_coef[:, None] * F_perp + sin_coef[:, None] * F_side) / m
    q_WB = _axis_quat(theta, k) * np.concatenate(([1.0], np.full(3, e[k])))  # rotation about ±e_k
    w_B = alpha * tc * e
    return q_WB, w_B, v_W, p_W
