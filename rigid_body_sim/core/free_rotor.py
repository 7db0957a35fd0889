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
from . import elliptic
from .quaternion import quat_conjugate, quat_from_matrix, quat_from_rotation_vector, quat_multiply, quat_rotate

__all__ = ["symmetric_split_rotor", "exact_rotor", "rotor_pairing", "EQUAL_MOMENTS_RTOL"]

#: Two principal moments this close (relative) count as equal: the body is a symmetric top
#: (reduction.py uses the same threshold for the symmetric and isotropic models).
EQUAL_MOMENTS_RTOL = 1e-12

#: Smallest m_c = 1 − m used: a body exactly on the separatrix (m = 1, period → ∞) is
#: integrated as one a hair inside it, period 4 K(1 − m_c) ≈ 4·347 in u; the two agree to
#: round-off for any step shorter than that (u advances by ν h per step). Not smaller:
#: scipy's Carlson integrals overflow to inf for m_c near the smallest normal float.
_MIN_M_C = 1e-300
#: A transverse amplitude below this fraction of |L| is treated as zero (a uniform spin about
#: the axis): what it would add is ~1e-150 relative, and its square would underflow.
_TINY_AMPLITUDE = 1e-150
#: Gauss–Legendre rule for the precession increment of a short step, and its reach: used when
#: |ν h| ≤ _GL_REACH · (half-width of the strip where the integrand is analytic).
_GL_NODES, _GL_WEIGHTS = np.polynomial.legendre.leggauss(8)
_GL_REACH = 0.25
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

        H_top = |L|²/(2 I_t) + ½ (1/I_s − 1/I_t) L_s²      (exact: :func:`_top_flow`)
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


def _top_flow(q: np.ndarray, L: np.ndarray, inv_inertia_t: np.ndarray, e_axis: np.ndarray, c_axis: np.ndarray,
              t: float) -> tuple[np.ndarray, np.ndarray]:
    """Exact flow over ``t`` of |L|²/(2 I_t) + ½ c L_a² (a = ``e_axis``), per body: (q, L) after it.

    The two terms commute (|L|² is a Casimir): the body turns about L at |L|/I_t (L fixed in
    the body's axes), then about e_a at c L_a, which turns L in the body's axes backwards.
    The compiled twin is kernels/integrators.top_flow; the tests' reference is the closed
    form of rigid_body_sim.exact (neither is imported here).
    """
    turn = quat_from_rotation_vector((c_axis * np.sum(L * e_axis, axis=-1) * t)[:, None] * e_axis)
    cone = quat_from_rotation_vector((inv_inertia_t * t)[:, None] * L)
    return quat_multiply(quat_multiply(q, cone), turn), quat_rotate(quat_conjugate(turn), L)


def _symmetric_split(pairing: _Pairing, q: np.ndarray, L: np.ndarray, h: float) -> tuple[np.ndarray, np.ndarray]:
    zero = np.zeros_like(pairing.c_k)
    q, L = _top_flow(q, L, zero, pairing.e_k, pairing.c_k, 0.5 * h)
    q, L = _top_flow(q, L, pairing.inv_inertia_t, pairing.e_s, pairing.c_s, h)
    return _top_flow(q, L, zero, pairing.e_k, pairing.c_k, 0.5 * h)


# ----------------------------------------------------------------------------- exact flow


def exact_rotor(inertia_P: np.ndarray, q_WP: np.ndarray, L_P: np.ndarray, h: float
                ) -> tuple[np.ndarray, np.ndarray]:
    """The exact torque-free motion over ``h`` (Euler–Poinsot), for any step size.

    Per body, in sorted axes (I1 < I2 < I3) and with the notation of
    :func:`~rigid_body_sim.exact.closed_form.asymmetric_top_body_rates` (same formulas,
    vectorised, on L/|L| so that no intermediate overflows):

    * ``L_P(h)``: Jacobi sn, cn, dn at ``u0 + ν h``, with ``u0 = F(am u0 | m)`` from the
      current state. The state's own sn, cn, dn are read off L (each to full relative
      precision, however close to an axis or to the separatrix), u0 is Carlson's R_F of them,
      m_c = 1 − m comes from L² − 2E·I2 formed with error-free products, and sn, cn, dn at the
      end come from Bulirsch's recurrence (:mod:`~rigid_body_sim.core.elliptic`), which keeps
      cn and dn to full relative precision where they are small. L is scaled by a power of two
      first (exact), so any |L| works; the result is rescaled to the input |L|.
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
      form cancels. Both are extended beyond |β| ≤ π/2 by their quasi-periodicity, and
      evaluated from (sn, cn, dn) of the reduced phases, never from β itself. For a short step
      (|ν h| ≤ a quarter of the strip where the integrand is analytic) the increment is instead
      integrated over [u0, u1] by 8-point Gauss–Legendre, so that its error is relative to the
      increment and not to G, which grows like ln(1/dn) near the intermediate axis.

    Special cases, all exact: L = 0 (nothing moves); L along a principal axis (a uniform
    rotation ``q ⊗ exp(h ω)``); a body whose closest pair of moments is equal within
    ``EQUAL_MOMENTS_RTOL`` (the symmetric top of :func:`symmetric_split_rotor`, whose remainder
    is then ≤ 1e-12 relative). A body exactly on the separatrix gets m_c = 1e-300 (_MIN_M_C).

    Parameters and returns as :func:`symmetric_split_rotor`.
    """
    pairing, constants = _constants(inertia_P)
    symmetric = pairing.symmetric
    if not symmetric.any():
        return _elliptic_flow(constants, inertia_P, q_WP, L_P, h)
    if symmetric.all():
        return _symmetric_split(pairing, q_WP, L_P, h)
    q_new = np.empty(np.broadcast_shapes(q_WP.shape, (len(inertia_P), 4)))
    L_new = np.empty(np.broadcast_shapes(L_P.shape, (len(inertia_P), 3)))
    idx = np.flatnonzero(symmetric)
    sub = _Pairing(*(getattr(pairing, f)[idx] for f in ("inv_inertia_t", "e_s", "c_s", "e_k", "c_k", "symmetric")))
    q_new[idx], L_new[idx] = _symmetric_split(sub, q_WP[idx], L_P[idx], h)
    idx = np.flatnonzero(~symmetric)
    sub = _Elliptic(*(getattr(constants, f)[idx] for f in ("P", "I_S", "n_char", "q_Q")))
    q_new[idx], L_new[idx] = _elliptic_flow(sub, inertia_P[idx], q_WP[idx], L_P[idx], h)
    return q_new, L_new


def _elliptic_flow(c: _Elliptic, inertia: np.ndarray, q: np.ndarray, L: np.ndarray, h: float
                   ) -> tuple[np.ndarray, np.ndarray]:
    """The exact flow for bodies with three distinct moments (see :func:`exact_rotor`).

    The phase of the current state is carried as the triple (sn, cn, dn) read off the state
    (each to full relative precision, however small), never as the angle β = am(u): near the
    intermediate axis with m ≈ 1, β ≈ π/2 and cos β = cn and Δ = dn ~ the distance to the
    saddle would keep only their absolute accuracy, ~1e-16 rad, and the precession integral,
    whose derivative there is ~1/Δ, would amplify that by 1/Δ at every step.
    """
    # Exact scaling by a power of two, so that nothing over- or underflows for any |L|.
    big = np.max(np.abs(L), axis=1)
    scale_exp = np.frexp(np.where(big > 0.0, big, 1.0))[1]
    l_S = np.ldexp(np.einsum("nij,nj->ni", c.P, L), -scale_exp[:, None])  # sorted axes, max |l_i| in [½, 1)
    l1, l2, l3 = l_S[:, 0], l_S[:, 1], l_S[:, 2]
    I1, I2, I3 = c.I_S[:, 0], c.I_S[:, 1], c.I_S[:, 2]
    d21, d31, d32 = I2 - I1, I3 - I1, I3 - I2
    g1, g2, g3 = np.sqrt(d31 / I1), np.sqrt(d32 / I2), np.sqrt(d21 / I2)
    g4 = np.sqrt(d31 / I3)
    # (x1, x2), (y2, y3): coordinates on the two ellipses of the polhode, x1² + x2² = D3 and
    # y2² + y3² = D1, where, per |L|² (2^-2e), D1 = L² − 2E I1, D3 = 2E I3 − L², D2 = L² − 2E I2.
    x1, x2, y2, y3 = g1 * l1, g2 * l2, g3 * l2, g4 * l3
    R3, R1 = np.hypot(x1, x2), np.hypot(y2, y3)  # √D3, √D1: sums of squares, no cancellation
    D2 = elliptic.difference_of_products(d32 / I3, l3, d21 / I1, l1)  # exact for the stored l
    size_l = np.sqrt(np.sum(l_S * l_S, axis=1))
    size = np.ldexp(size_l, scale_exp)  # |L|

    # L = 0, L within 1e-150 of a principal axis: a uniform rotation (below).
    uniform = ((big == 0.0) | (np.minimum(R1, R3) < _TINY_AMPLITUDE * size_l)
               | (np.maximum(np.abs(l1), np.abs(l3)) < _TINY_AMPLITUDE * size_l))
    case1 = D2 > 0.0  # polhode about axis 3; else about axis 1
    with np.errstate(divide="ignore", invalid="ignore"):  # uniform lanes may divide by zero; replaced below
        sigma = np.where(case1, np.sign(l3), np.sign(l1))
        sigma = np.where(sigma == 0.0, 1.0, sigma)
        sn0 = np.where(case1, x2 / R3, y2 / R1)
        cn0 = sigma * np.where(case1, x1 / R3, y3 / R1)
        dn0 = np.where(case1, np.abs(y3) / R1, np.abs(x1) / R3)
        den = np.where(case1, d32 * R1 * R1, d21 * R3 * R3)
        nu_l = np.sqrt(den / (I1 * I2 * I3))  # du/dt per unit 2^e, 1/(kg·m²)
        nu = np.ldexp(nu_l, scale_exp)  # du/dt, rad/s
        m = np.where(case1, d21 * R3 * R3, d32 * R1 * R1) / den
        m_c = np.maximum(np.abs(D2) * d31 / den, _MIN_M_C)
        two_K = 2.0 * elliptic.complete_k(m_c)

        # Phase: u0 = 2K j0 + r0 with r0 ∈ [−K, K] (cn(r0) ≥ 0), then u1 = u0 + ν h likewise.
        j0 = np.where(cn0 < 0.0, 1.0, 0.0)
        sr0, cr0 = np.where(cn0 < 0.0, -sn0, sn0), np.abs(cn0)
        r0 = elliptic.elliptic_f(sr0, cr0, dn0)
        tau = nu * h
        dj, r1 = elliptic.reduce_phase(r0 + tau, two_K)
        j1 = j0 + dj
        # A short step also needs sn at the Gauss–Legendre nodes of [u0, u1] (below): one call.
        n = np.where(case1, c.n_char[:, 0], c.n_char[:, 1])
        short = np.abs(tau) <= _GL_REACH * np.arctan(1.0 / np.sqrt(np.abs(n)))
        if short.all():
            _, nodes = elliptic.reduce_phase(r0[:, None] + tau[:, None] * (0.5 * (_GL_NODES + 1.0)), two_K[:, None])
            sn_all, cn_all, dn_all = elliptic.jacobi_reduced(np.column_stack((r1, nodes)), m_c[:, None])
            sr1, cr1, dr1, sn_nodes = sn_all[:, 0], cn_all[:, 0], dn_all[:, 0], sn_all[:, 1:]
        else:
            sr1, cr1, dr1 = elliptic.jacobi_reduced(r1, m_c)
            if short.any():
                sn_nodes = np.empty((len(r1), _GL_NODES.size))
                _, nodes = elliptic.reduce_phase(r0[short, None] + tau[short, None] * (0.5 * (_GL_NODES + 1.0)),
                                                 two_K[short, None])
                sn_nodes[short] = elliptic.jacobi_reduced(nodes, m_c[short, None])[0]
        parity = 1.0 - 2.0 * np.mod(j1, 2.0)  # sn, cn change sign every 2K; dn does not
        sn1, cn1 = parity * sr1, parity * cr1
        l_S1 = np.where(case1[:, None],
                        np.stack((sigma * cn1 * R3 / g1, sn1 * R3 / g2, sigma * dr1 * R1 / g4), axis=1),
                        np.stack((sigma * dr1 * R3 / g1, sn1 * R1 / g3, sigma * cn1 * R1 / g4), axis=1))

        # Precession angle about L_W: G = Π − F (or Π, `large`) at both ends, plus whole periods.
        large = np.abs(n) > 1.0
        dG = (_third_kind(sr1, cr1, dr1, n, m, large) - _third_kind(sr0, cr0, dn0, n, m, large)
              + 2.0 * dj * _third_kind_complete(n, m, m_c, large))
        # A short step: the increment itself, ∫ dG/du du over [u0, u1] by Gauss–Legendre, so its
        # error is relative to the increment rather than ulp(G) (G ~ ln(1/dn) near the saddle).
        if short.any():
            dG[short] = _third_kind_increment(sn_nodes[short], tau[short], n[short], large[short])
        K = d31 / (I1 * I3 * nu_l) * size_l
        I_base = np.where(case1 ^ large, I1, I3)
        dphi = size * h / I_base + np.where(case1, K, -K) * dG

        # Body turn: Q* ⊗ B(L0)* ⊗ Rz(Δφ) ⊗ B(L1) ⊗ Q in (a, b, c) = cyclic relabel of S, with
        # B(L) = Rx(θ) Rz(ψ), ψ = atan2(L_a, L_b) on its branch continuous in u (so Δq → +1 as
        # h → 0): ψ = A + B (jπ + χ), χ = atan2(q sn(r), p cn(r)) ∈ [−π/2, π/2]; the jπ part is
        # applied as an exact quaternion so that a large j costs no accuracy.
        relabel = np.where(case1[:, None], np.array([0, 1, 2]), np.array([1, 2, 0]))
        qp = np.where(case1, np.sqrt(I2 * d31 / (I1 * d32)), np.sqrt(I2 * d31 / (I3 * d21)))  # q/p
        psi_sign = np.where(case1, -sigma, sigma)
        psi_offset = np.where(case1, 0.5 * np.pi * sigma, np.where(sigma > 0.0, 0.0, np.pi))
        B0 = _to_z(np.take_along_axis(l_S, relabel, axis=1),
                   psi_offset + psi_sign * np.arctan2(qp * sr0, cr0), psi_sign * j0)
        B1 = _to_z(np.take_along_axis(l_S1, relabel, axis=1),
                   psi_offset + psi_sign * np.arctan2(qp * sr1, cr1), psi_sign * j1)
        q_Q = np.where(case1[:, None], c.q_Q[:, 0], c.q_Q[:, 1])
        turn_abc = quat_multiply(quat_multiply(quat_conjugate(B0), _z_quat(dphi)), B1)
        turn = quat_multiply(quat_multiply(quat_conjugate(q_Q), turn_abc), q_Q)
        q_out = quat_multiply(q, turn)
        l_S1 = _onto_invariants(l_S1, l_S, 1.0 / c.I_S)
        L_out = np.ldexp(np.einsum("nji,nj->ni", c.P, l_S1), scale_exp[:, None])

    if uniform.any():
        w_P = L[uniform] / inertia[uniform]
        q_out[uniform] = quat_multiply(q[uniform], quat_from_rotation_vector(h * w_P))
        L_out[uniform] = L[uniform]
    return q_out, L_out


def _weighted_square_sum(l: np.ndarray, weight: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Σ_i weight_i l_i² per row as an unevaluated sum hi + lo, to ~ulp² (error-free products)."""
    square, square_err = elliptic.two_product(l, l)
    term, term_err = elliptic.two_product(weight, square)
    hi, err1 = elliptic.two_sum(term[:, 0], term[:, 1])
    hi, err2 = elliptic.two_sum(hi, term[:, 2])
    lo = err1 + err2 + np.sum(term_err + weight * square_err, axis=1)
    return hi, lo


def _onto_invariants(l_new: np.ndarray, l_old: np.ndarray, inv_inertia: np.ndarray) -> np.ndarray:
    """``l_new`` moved by ~1 ulp so that |l|² and Σ l²/I equal those of ``l_old`` to ~ulp².

    The exact flow keeps both; the elliptic-function evaluation keeps them only to a few ulp,
    with a small systematic bias (sums of squares of rounded values near 1), which over 10⁵
    steps adds up to ~1e-12 in |L| and E and so to ~1e-10 rad of phase for a body that turns
    100 rad. One Newton step along the two gradients l and l/I, with both residuals formed
    with error-free products, leaves only the final rounding of l, which is unbiased. Near a
    principal axis the two gradients are parallel and only |l| is corrected.
    """
    size2_old, size2_old_lo = _weighted_square_sum(l_old, np.ones_like(inv_inertia))
    size2_new, size2_new_lo = _weighted_square_sum(l_new, np.ones_like(inv_inertia))
    energy_old, energy_old_lo = _weighted_square_sum(l_old, inv_inertia)
    energy_new, energy_new_lo = _weighted_square_sum(l_new, inv_inertia)
    res_size = (size2_new - size2_old) + (size2_new_lo - size2_old_lo)  # the first difference is exact
    res_energy = (energy_new - energy_old) + (energy_new_lo - energy_old_lo)
    g = l_new * inv_inertia  # ½ gradient of Σ l²/I; ½ gradient of |l|² is l_new
    a11 = np.sum(l_new * l_new, axis=1)
    a12 = np.sum(l_new * g, axis=1)
    a22 = np.sum(g * g, axis=1)
    det = a11 * a22 - a12 * a12
    both = det > 1e-8 * a11 * a22
    with np.errstate(divide="ignore", invalid="ignore"):
        lam1 = np.where(both, (a22 * res_size - a12 * res_energy) / det, res_size / a11)
        lam2 = np.where(both, (a11 * res_energy - a12 * res_size) / det, 0.0)
    return l_new - 0.5 * (lam1[:, None] * l_new + lam2[:, None] * g)


def _third_kind(s: np.ndarray, c: np.ndarray, delta: np.ndarray, n: np.ndarray, m: np.ndarray,
                large: np.ndarray) -> np.ndarray:
    """Π(n; β | m) − F(β | m) where not ``large``, Π(n; β | m) where ``large``; β ∈ [−π/2, π/2], n ≤ 0.

    From (sin β, cos β ≥ 0, Δ). For |n| > 1, ``Π(n) = F − Π(n') + ρ^{-1/2} atan(√ρ tan β / Δ)``
    with ``n' = m/n``, ``ρ = (1 − n)(1 − n')`` (DLMF 19.7.9), so that neither form cancels.
    """
    n_used = np.where(large, m / np.where(large, n, -1.0), n)
    part = elliptic.third_kind_minus_f(s, c, delta, n_used)
    root = np.sqrt(np.where(large, (1.0 - n) * (1.0 - n_used), 1.0))
    return np.where(large, np.arctan2(root * s, c * delta) / root - part, part)


def _third_kind_increment(sn_nodes: np.ndarray, tau: np.ndarray, n: np.ndarray, large: np.ndarray) -> np.ndarray:
    """:func:`_third_kind` at u0 + τ minus at u0, by 8-point Gauss–Legendre in u (``sn_nodes``
    (N, 8) the values of sn at u0 + τ (1 + x_i)/2).

    The integrand, d(Π − F)/du = n sn²/(1 − n sn²) or dΠ/du = 1/(1 − n sn²) (``large``), is
    analytic in a strip |Im u| < atan(1/√|n|) (where 1 − n sn² = 0 nearest the real axis, and
    ≤ K' for the poles of sn); for |τ| ≤ ``_GL_REACH`` · that width the 8-point rule's error is
    ≲ ρ^-16 ≈ 3e-15 of the increment (ρ ≈ 4/_GL_REACH, the Bernstein ellipse that fits).
    """
    s2 = sn_nodes * sn_nodes
    n = n[:, None]
    rate = np.where(large[:, None], 1.0, n * s2) / (1.0 - n * s2)
    return 0.5 * tau * (rate @ _GL_WEIGHTS)


def _third_kind_complete(n: np.ndarray, m: np.ndarray, m_c: np.ndarray, large: np.ndarray) -> np.ndarray:
    """:func:`_third_kind` at β = π/2 (its increment over a half period is twice this)."""
    n_used = np.where(large, m / np.where(large, n, -1.0), n)
    part = elliptic.third_kind_minus_f_complete(n_used, m_c)
    root = np.sqrt(np.where(large, (1.0 - n) * (1.0 - n_used), 1.0))
    return np.where(large, 0.5 * np.pi / root - part, part)


def _to_z(l_abc: np.ndarray, psi: np.ndarray, half_turns: np.ndarray) -> np.ndarray:
    """Quaternion of Rx(θ) Rz(ψ + kπ), the rotation taking the unit vector ``l_abc`` to e_z.

    θ = atan2(√(a² + b²), c), ψ + kπ ≡ atan2(a, b) (mod 2π), k = ``half_turns`` an integer:
    qx(θ) ⊗ qz(ψ) written out, times qz(kπ) = (cos kπ/2, 0, 0, sin kπ/2), which is exact.
    """
    theta = np.arctan2(np.hypot(l_abc[:, 0], l_abc[:, 1]), l_abc[:, 2])
    cx, sx = np.cos(0.5 * theta), np.sin(0.5 * theta)
    cz, sz = np.cos(0.5 * psi), np.sin(0.5 * psi)
    k = np.mod(half_turns, 4.0)
    half_turn = np.zeros((len(k), 4))
    half_turn[:, 0] = np.where(k == 0.0, 1.0, np.where(k == 2.0, -1.0, 0.0))
    half_turn[:, 3] = np.where(k == 1.0, 1.0, np.where(k == 3.0, -1.0, 0.0))
    return quat_multiply(np.stack((cx * cz, sx * cz, -sx * sz, cx * sz), axis=1), half_turn)


def _z_quat(angle: np.ndarray) -> np.ndarray:
    half = 0.5 * angle
    zero = np.zeros_like(half)
    return np.stack((np.cos(half), zero, zero, np.sin(half)), axis=1)
