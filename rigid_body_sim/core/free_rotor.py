"""Torque-free rotation of N rigid bodies over one step, vectorised over bodies.

The free-rotor stages of two splitting integrators (integrators.py), both on the body-frame
angular momentum ``L_P`` (kg·m²/s, principal axes) and the (w, x, y, z) quaternion ``q_WP``:

:func:`symmetric_split_rotor`
    Strang splitting of ``H = Σ L_i²/(2 I_i)`` into an exactly solvable symmetric top around
    the two closest principal moments and a single-axis remainder, itself an exact rotation.
    The error is proportional to the remainder, i.e. to how far the body is from symmetric, so
    a rod I = (r, 1, 1 + r/2) is integrated almost exactly however fast it spins about its axis.
:func:`exact_rotor`
    The exact Euler–Poinsot flow: ``L_P(t)`` by Jacobi elliptic functions and the precession
    angle about the fixed ``L_W`` by Legendre's incomplete elliptic integral of the third kind,
    in Carlson's symmetric forms (Celledoni, Fassò, Säfström & Zanna, SIAM J. Sci. Comput. 30,
    2008). Energy and |L| are kept to round-off at any step size.

Both are pure functions of (inertia, q, L, h) that return a new (q, L); per-body constants
that depend only on the inertia are computed once per set of moments and cached.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import special

from .closed_form import EQUAL_MOMENTS_RTOL, _elliptic_f, _jacobi, symmetric_top_flow
from .quaternion import quat_conjugate, quat_from_matrix, quat_from_rotation_vector, quat_multiply

__all__ = ["symmetric_split_rotor", "exact_rotor", "rotor_pairing"]

#: Smallest m_c = 1 − m used: a body exactly on the separatrix (m = 1, period → ∞) is
#: integrated as one a hair inside it, period 4 K(1 − m_c) ≈ 4·347 in u; the two agree to
#: round-off for any step shorter than that (u advances by ν h per step). Not smaller:
#: scipy's Carlson integrals overflow to inf for m_c near the smallest normal float.
_MIN_M_C = 1e-300
#: How many sets of moments keep their constants cached.
_CACHE_SIZE = 16


# ----------------------------------------------------------------------------- per-body constants


@dataclass(frozen=True)
class _Pairing:
    """Axes of the symmetric-top splitting, per body (see :func:`rotor_pairing`)."""

    inv_inertia_t: np.ndarray  # (N,) 1/I_t, I_t the median moment
    e_s: np.ndarray  # (N, 3) one-hot symmetry axis of the top
    c_s: np.ndarray  # (N,) 1/I_s − 1/I_t
    e_k: np.ndarray  # (N, 3) one-hot remainder axis
    c_k: np.ndarray  # (N,) 1/I_k − 1/I_t
    symmetric: np.ndarray  # (N,) bool: the closest pair is equal within EQUAL_MOMENTS_RTOL


@dataclass(frozen=True)
class _Elliptic:
    """Constants of the Euler–Poinsot solution, per body, in sorted axes S (I1 ≤ I2 ≤ I3)."""

    P: np.ndarray  # (N, 3, 3) signed permutation, det +1: x_S = P x_P
    I_S: np.ndarray  # (N, 3) sorted moments
    n_char: np.ndarray  # (N, 2) characteristic n of Π in case 1 and case 2 (both ≤ 0)
    q_Q: np.ndarray  # (N, 2, 4) quaternion of Q = (cyclic relabel of case c) · P, x_abc = Q x_P


_cache: dict[bytes, tuple[_Pairing, _Elliptic]] = {}


def _constants(inertia_P: np.ndarray) -> tuple[_Pairing, _Elliptic]:
    key = inertia_P.tobytes() + bytes(str(inertia_P.shape), "ascii")
    found = _cache.get(key)
    if found is None:
        if len(_cache) >= _CACHE_SIZE:
            _cache.pop(next(iter(_cache)))
        found = _cache[key] = (_pairing(inertia_P), _elliptic_constants(inertia_P))
    return found


def rotor_pairing(inertia_P: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The axes :func:`symmetric_split_rotor` pairs, per body.

    The transverse moment I_t is the median moment (axis t); the remainder axis k is the other
    member of the closest pair, the one with the smallest relative gap ``|I_k − I_t| / max``
    (the closest pair always contains the median); the symmetry axis s is the third.

    Parameters
    ----------
    inertia_P : ndarray, shape (N, 3)
        Principal moments, kg·m².

    Returns
    -------
    t, s, k : ndarray of int, shape (N,)
        Axis indices (0, 1, 2) of the transverse, symmetry and remainder axes.
    """
    inertia = np.asarray(inertia_P, dtype=float)
    rows = np.arange(len(inertia))
    order = np.argsort(inertia, axis=1, kind="stable")
    low, mid, high = order[:, 0], order[:, 1], order[:, 2]
    I_low, I_mid, I_high = inertia[rows, low], inertia[rows, mid], inertia[rows, high]
    low_is_closer = (I_mid - I_low) / I_mid <= (I_high - I_mid) / I_high
    k = np.where(low_is_closer, low, high)
    s = np.where(low_is_closer, high, low)
    return mid, s, k


def _pairing(inertia: np.ndarray) -> _Pairing:
    rows = np.arange(len(inertia))
    t, s, k = rotor_pairing(inertia)
    I_t, I_s, I_k = inertia[rows, t], inertia[rows, s], inertia[rows, k]
    eye = np.eye(3)
    return _Pairing(
        inv_inertia_t=1.0 / I_t,
        e_s=eye[s],
        c_s=1.0 / I_s - 1.0 / I_t,
        e_k=eye[k],
        c_k=1.0 / I_k - 1.0 / I_t,
        symmetric=np.abs(I_k - I_t) <= EQUAL_MOMENTS_RTOL * np.maximum(I_k, I_t),
    )


def _elliptic_constants(inertia: np.ndarray) -> _Elliptic:
    n = len(inertia)
    order = np.argsort(inertia, axis=1, kind="stable")
    P = np.zeros((n, 3, 3))
    P[np.arange(n)[:, None], np.arange(3)[None, :], order] = 1.0
    P[np.linalg.det(P) < 0.0, 0, :] *= -1.0  # a proper rotation keeps Euler's equations' form
    I_S = np.take_along_axis(inertia, order, axis=1)
    I1, I2, I3 = I_S[:, 0], I_S[:, 1], I_S[:, 2]
    with np.errstate(divide="ignore", invalid="ignore"):  # equal moments: those bodies use the symmetric top
        n_char = np.stack((-I3 * (I2 - I1) / (I1 * (I3 - I2)), -I1 * (I3 - I2) / (I3 * (I2 - I1))), axis=1)
    cyclic = np.eye(3)[[1, 2, 0]]  # case 2 relabels S = (1, 2, 3) as (a, b, c) = (2, 3, 1)
    q_Q = np.stack((quat_from_matrix(P), quat_from_matrix(cyclic @ P)), axis=1)
    return _Elliptic(P=P, I_S=I_S, n_char=n_char, q_Q=q_Q)


# ----------------------------------------------------------------------------- symmetric-top splitting


def symmetric_split_rotor(inertia_P: np.ndarray, q_WP: np.ndarray, L_P: np.ndarray, h: float
                          ) -> tuple[np.ndarray, np.ndarray]:
    """Free rotor over ``h`` by Strang splitting around an exact symmetric top.

    ``H = H_top + H_rem`` with, per body (axes from :func:`rotor_pairing`),

        H_top = |L|²/(2 I_t) + ½ (1/I_s − 1/I_t) L_s²      (exact: closed_form.symmetric_top_flow)
        H_rem = ½ (1/I_k − 1/I_t) L_k²                     (exact: a rotation about axis k)

    composed as rem(h/2) · top(h) · rem(h/2). Every stage is an exact rotation, so |L| and
    L_W are conserved to round-off; the splitting error is second order and proportional to
    (1/I_k − 1/I_t), which vanishes for a symmetric body (then the step is exact) and is
    ~r/2 for a rod (r, 1, 1 + r/2).

    Parameters
    ----------
    inertia_P : ndarray, shape (N, 3)
        Principal moments, kg·m².
    q_WP : ndarray, shape (N, 4)
        (w, x, y, z) quaternions of the principal frames.
    L_P : ndarray, shape (N, 3)
        Angular momenta, principal axes, kg·m²/s.
    h : float
        Step, s.

    Returns
    -------
    q_WP, L_P : ndarray, shapes (N, 4), (N, 3)
        After the step (q not renormalised).
    """
    pairing, _ = _constants(inertia_P)
    return _symmetric_split(pairing, q_WP, L_P, h)


def _symmetric_split(pairing: _Pairing, q: np.ndarray, L: np.ndarray, h: float) -> tuple[np.ndarray, np.ndarray]:
    zero = np.zeros_like(pairing.c_k)
    q, L = symmetric_top_flow(q, L, zero, pairing.e_k, pairing.c_k, 0.5 * h)
    q, L = symmetric_top_flow(q, L, pairing.inv_inertia_t, pairing.e_s, pairing.c_s, h)
    return symmetric_top_flow(q, L, zero, pairing.e_k, pairing.c_k, 0.5 * h)


# ----------------------------------------------------------------------------- exact flow


def exact_rotor(inertia_P: np.ndarray, q_WP: np.ndarray, L_P: np.ndarray, h: float
                ) -> tuple[np.ndarray, np.ndarray]:
    """The exact torque-free motion over ``h`` (Euler–Poinsot), for any step size.

    Per body, in sorted axes (I1 < I2 < I3) and with the notation of
    :func:`~rigid_body_sim.core.closed_form.asymmetric_top_body_rates` (same formulas,
    vectorised, on L/|L| so that no intermediate overflows):

    * ``L_P(h)``: Jacobi sn, cn, dn at ``u0 + ν h``, with ``u0 = F(am u0 | m)`` from the
      current state.
    * Orientation: with (a, b, c) the sorted axes relabelled cyclically so that c is the axis
      the polhode encircles, and ``B(L)`` the rotation ``Rx(θ) Rz(ψ)`` taking ``L_abc`` to
      ``|L| e_z`` (z–x–z Euler angles, Landau & Lifshitz §37), the body turns by
      ``Δq = Q* ⊗ B(L0)* ⊗ Rz(Δφ) ⊗ B(L1) ⊗ Q``. The precession angle
      ``Δφ = ∫ |L| (2E − L_c²/I_c) / (|L|² − L_c²) dt`` is, exactly,

          case 1 (c = 3):  Δφ = |L| h / I1 + K Δ[Π(n; β) − F(β)] = |L| h / I3 + K Δ Π(n; β),
          case 2 (c = 1):  Δφ = |L| h / I3 − K Δ[Π(n; β) − F(β)] = |L| h / I1 − K Δ Π(n; β),

      with ``K = |L| (I3 − I1) / (I1 I3 ν)``, ``β = am(u)``, ``n = −I3 (I2 − I1) / (I1 (I3 − I2))``
      (case 1) or ``−I1 (I3 − I2) / (I3 (I2 − I1))`` (case 2). For |n| ≤ 1 the first form is
      used, ``Π − F = (n/3) sin³β R_J(cos²β, Δ², 1, 1 − n sin²β)``; for |n| > 1 (a
      near-symmetric body tumbling about its odd axis) the second, with
      ``Π(n) = F − Π(m/n) + ρ^{-1/2} atan(√ρ tan β / Δ)``, ``ρ = (1 − n)(1 − m/n)``, so that
      ``Π = −(n'/3) sin³β R_J(…, 1 − n' sin²β) + ρ^{-1/2} atan(…)`` with ``n' = m/n``: neither
      form cancels. Both are extended beyond |β| ≤ π/2 by their quasi-periodicity.

    Special cases, all exact: L = 0 (nothing moves); L along a principal axis (a uniform
    rotation ``q ⊗ exp(h ω)``); a body whose closest pair of moments is equal within
    ``EQUAL_MOMENTS_RTOL`` (the symmetric top of :func:`symmetric_split_rotor`, whose remainder
    is then ≤ 1e-12 relative). A body exactly on the separatrix gets m_c = 1e-300 (_MIN_M_C).

    Parameters and returns as :func:`symmetric_split_rotor`.
    """
    pairing, elliptic = _constants(inertia_P)
    symmetric = pairing.symmetric
    if not symmetric.any():
        return _elliptic_flow(elliptic, inertia_P, q_WP, L_P, h)
    if symmetric.all():
        return _symmetric_split(pairing, q_WP, L_P, h)
    q_new = np.empty(np.broadcast_shapes(q_WP.shape, (len(inertia_P), 4)))
    L_new = np.empty(np.broadcast_shapes(L_P.shape, (len(inertia_P), 3)))
    idx = np.flatnonzero(symmetric)
    sub = _Pairing(*(getattr(pairing, f)[idx] for f in ("inv_inertia_t", "e_s", "c_s", "e_k", "c_k", "symmetric")))
    q_new[idx], L_new[idx] = _symmetric_split(sub, q_WP[idx], L_P[idx], h)
    idx = np.flatnonzero(~symmetric)
    sub = _Elliptic(*(getattr(elliptic, f)[idx] for f in ("P", "I_S", "n_char", "q_Q")))
    q_new[idx], L_new[idx] = _elliptic_flow(sub, inertia_P[idx], q_WP[idx], L_P[idx], h)
    return q_new, L_new


def _elliptic_flow(c: _Elliptic, inertia: np.ndarray, q: np.ndarray, L: np.ndarray, h: float
                   ) -> tuple[np.ndarray, np.ndarray]:
    """The exact flow for bodies with three distinct moments (see :func:`exact_rotor`)."""
    size = np.sqrt(np.sum(L * L, axis=1))  # |L|
    # Masked-out lanes (L = 0, pure spins) may divide by zero; they are replaced below.
    with np.errstate(divide="ignore", invalid="ignore"):
        l_S = np.einsum("nij,nj->ni", c.P, L / size[:, None])  # unit L, sorted axes
        I1, I2, I3 = c.I_S[:, 0], c.I_S[:, 1], c.I_S[:, 2]
        w1, w2, w3 = l_S[:, 0] / I1, l_S[:, 1] / I2, l_S[:, 2] / I3  # ω/|L|
        # The three combinations of energy and momentum, without cancellation (closed_form):
        D1 = I2 * (I2 - I1) * w2**2 + I3 * (I3 - I1) * w3**2  # (L² − 2E I1)/|L|²
        D3 = I1 * (I3 - I1) * w1**2 + I2 * (I3 - I2) * w2**2  # (2E I3 − L²)/|L|²
        D2 = I3 * (I3 - I2) * w3**2 - I1 * (I2 - I1) * w1**2  # (L² − 2E I2)/|L|²
        case1 = D2 > 0.0  # polhode about axis 3; else about axis 1
        sigma = np.where(case1, np.sign(w3), np.sign(w1))
        sigma = np.where(sigma == 0.0, 1.0, sigma)
        a1 = np.sqrt(D3 / (I1 * (I3 - I1)))
        a3 = np.sqrt(D1 / (I3 * (I3 - I1)))
        a2 = np.sqrt(np.where(case1, D3 / (I2 * (I3 - I2)), D1 / (I2 * (I2 - I1))))
        den = np.where(case1, (I3 - I2) * D1, (I2 - I1) * D3)
        nu = np.sqrt(den / (I1 * I2 * I3)) * size  # du/dt, rad/s
        m = np.where(case1, (I2 - I1) * D3, (I3 - I2) * D1) / den
        m_c = np.maximum(np.abs(D2) * (I3 - I1) / den, _MIN_M_C)
        beta0 = np.where(case1, np.arctan2(w2 * a1, sigma * w1 * a2), np.arctan2(w2 * a3, sigma * w3 * a2))
        u1 = _elliptic_f(beta0, m_c) + nu * h
        two_K = 2.0 * special.ellipkm1(m_c)
        periods = np.floor(u1 / two_K)
        sn, cn, dn, am = _jacobi(np.clip(u1 - periods * two_K, 0.0, two_K), m, m_c)
        parity = 1.0 - 2.0 * np.mod(periods, 2.0)  # sn, cn change sign every 2K; dn does not
        sn, cn = parity * sn, parity * cn
        beta1 = np.pi * periods + am
        l_S1 = c.I_S * np.where(case1[:, None],
                                np.stack((sigma * a1 * cn, a2 * sn, sigma * a3 * dn), axis=1),
                                np.stack((sigma * a1 * dn, a2 * sn, sigma * a3 * cn), axis=1))

        # Precession angle about L_W.
        n = np.where(case1, c.n_char[:, 0], c.n_char[:, 1])
        large = np.abs(n) > 1.0
        K = (I3 - I1) / (I1 * I3 * nu) * size
        dG = _third_kind(beta1, n, m, m_c, large) - _third_kind(beta0, n, m, m_c, large)
        I_base = np.where(case1 ^ large, I1, I3)
        dphi = size * h / I_base + np.where(case1, K, -K) * dG

        # Body turn: Q* ⊗ B(L0)* ⊗ Rz(Δφ) ⊗ B(L1) ⊗ Q, in (a, b, c) = cyclic relabel of S.
        # ψ = atan2(L_a, L_b) is taken on its continuous branch through β (as closed_form does),
        # so Δq is continuous in h from the identity: the quaternion keeps its sign branch.
        relabel = np.where(case1[:, None], np.array([0, 1, 2]), np.array([1, 2, 0]))
        p_amp = np.where(case1, I1 * a1, I3 * a3)
        q_amp = I2 * a2
        B0 = _to_z(np.take_along_axis(l_S, relabel, axis=1), _psi(beta0, p_amp, q_amp, case1, sigma))
        B1 = _to_z(np.take_along_axis(l_S1, relabel, axis=1), _psi(beta1, p_amp, q_amp, case1, sigma))
        q_Q = np.where(case1[:, None], c.q_Q[:, 0], c.q_Q[:, 1])
        turn_abc = quat_multiply(quat_multiply(quat_conjugate(B0), _z_quat(dphi)), B1)
        turn = quat_multiply(quat_multiply(quat_conjugate(q_Q), turn_abc), q_Q)
        q_out = quat_multiply(q, turn)
        L_out = np.einsum("nji,nj->ni", c.P, l_S1) * size[:, None]

    # L = 0, L along a principal axis (or a transverse part that underflowed): uniform rotation.
    uniform = (size == 0.0) | (np.where(case1, D3, D1) == 0.0) | ((w1 == 0.0) & (w3 == 0.0))
    if uniform.any():
        w_P = L[uniform] / inertia[uniform]
        q_out[uniform] = quat_multiply(q[uniform], quat_from_rotation_vector(h * w_P))
        L_out[uniform] = L[uniform]
    return q_out, L_out


def _third_kind(beta: np.ndarray, n: np.ndarray, m: np.ndarray, m_c: np.ndarray, large: np.ndarray) -> np.ndarray:
    """Π(n; β | m) − F(β | m) where not ``large``, Π(n; β | m) where ``large``; any real β, n ≤ 0."""
    j = np.round(beta / np.pi)
    r = beta - j * np.pi  # in [−π/2, π/2]: cos r ≥ 0
    s, c = np.sin(r), np.cos(r)
    delta2 = c * c + m_c * s * s  # 1 − m sin²r without cancellation
    n_used = np.where(large, m / np.where(large, n, -1.0), n)  # n' = m/n in the large form
    part = (n_used / 3.0) * s**3 * special.elliprj(c * c, delta2, 1.0, 1.0 - n_used * s * s)
    complete = (n_used / 3.0) * special.elliprj(0.0, m_c, 1.0, 1.0 - n_used)
    root = np.sqrt(np.where(large, (1.0 - n) * (1.0 - n_used), 1.0))
    value = np.where(large, np.arctan2(root * s, c * np.sqrt(delta2)) / root - part, part)
    complete = np.where(large, 0.5 * np.pi / root - complete, complete)
    return value + 2.0 * j * complete


def _psi(beta: np.ndarray, p: np.ndarray, q: np.ndarray, case1: np.ndarray, sigma: np.ndarray) -> np.ndarray:
    """ψ = atan2(L_a, L_b) on the branch continuous in β (closed_form.asymmetric_top).

    With χ = β + atan2((q − p) sin β cos β, p cos²β + q sin²β), the continuous branch of
    atan2(q sin β, p cos β): case 1 ψ = σ (π/2 − χ); case 2 ψ = χ (σ > 0) or π − χ (σ < 0).
    """
    s, c = np.sin(beta), np.cos(beta)
    chi = beta + np.arctan2((q - p) * s * c, p * c * c + q * s * s)
    return np.where(case1, sigma * (0.5 * np.pi - chi), np.where(sigma > 0.0, chi, np.pi - chi))


def _to_z(l_abc: np.ndarray, psi: np.ndarray) -> np.ndarray:
    """Quaternion of Rx(θ) Rz(ψ), the rotation taking the unit vector ``l_abc`` to e_z.

    θ = atan2(√(a² + b²), c) and ψ ≡ atan2(a, b) (mod 2π, given); qx(θ) ⊗ qz(ψ) written out.
    """
    theta = np.arctan2(np.hypot(l_abc[:, 0], l_abc[:, 1]), l_abc[:, 2])
    cx, sx = np.cos(0.5 * theta), np.sin(0.5 * theta)
    cz, sz = np.cos(0.5 * psi), np.sin(0.5 * psi)
    return np.stack((cx * cz, sx * cz, -sx * sz, cx * sz), axis=1)


def _z_quat(angle: np.ndarray) -> np.ndarray:
    half = 0.5 * angle
    zero = np.zeros_like(half)
    return np.stack((np.cos(half), zero, zero, np.sin(half)), axis=1)
