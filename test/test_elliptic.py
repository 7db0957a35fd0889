"""``rigid_body_sim.core.elliptic`` against values that do not come from it.

Independent sides: ``scipy.special`` where it is accurate (ellipj, ellipkinc for m ≤ 0.999,
ellipk); the Jacobi functions' own ODE s' = c d, c' = −s d, d' = −m s c integrated by DOP853;
exact rational arithmetic (``fractions.Fraction``) for the error-free products; and identities
that tie small values near K to ordinary values near 0 (the reflection sn(K − v) = cd v, ...),
which is where a naive algorithm loses its relative accuracy. Tolerances are in units of
EPS times the conditioning of the function at the argument (an argument u is only known to
ulp(u), so a value f(u) to |u f'(u)| ulp).
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest
from scipy import special
from scipy.integrate import quad, solve_ivp

from rigid_body_sim.core import elliptic as el

EPS = np.finfo(float).eps
M_C = [1.0, 0.9, 0.5, 1e-2, 1e-6, 1e-10, 1e-13, 1e-16, 1e-20, 1e-40, 1e-100, 1e-300]


def test_jacobi_equals_scipy_where_scipy_is_accurate() -> None:
    for m in (0.0, 0.1, 0.5, 0.9, 0.999):
        u = np.linspace(-3.0 * special.ellipk(m), 3.0 * special.ellipk(m), 101)
        ours = el.jacobi(u, 1.0 - m)
        sn, cn, dn, _ = special.ellipj(u, m)
        for a, b in zip(ours, (sn, cn, dn)):
            assert np.max(np.abs(a - b)) < 2e-14


@pytest.mark.parametrize("m_c", [0.5, 1e-6, 1e-12])
def test_jacobi_solves_its_differential_equation(m_c: float) -> None:
    """s' = c d, c' = −s d, d' = −m s c from (0, 1, 1), by DOP853, over a period 4K or up to 0.8 K.

    Near m = 1 the ODE has a saddle at u = K (sn = 1) that amplifies the solver's error by
    ~1/√m_c on the way out, so there the span stops short of it (the functions still go from
    0 to within ~1e-5 of the saddle).
    """
    m = 1.0 - m_c
    K = el.complete_k(m_c)
    u = np.linspace(0.0, 4.0 * K if m_c > 0.1 else 0.8 * K, 41)
    sol = solve_ivp(lambda _u, y: [y[1] * y[2], -y[0] * y[2], -m * y[0] * y[1]], (0.0, u[-1]), [0.0, 1.0, 1.0],
                    method="DOP853", rtol=1e-13, atol=1e-15, t_eval=u)
    ours = np.array(el.jacobi(u, m_c))
    # DOP853's global error over a 4K span with the near-separatrix saddle at K, 3K:
    assert np.max(np.abs(ours - sol.y)) < 1e-10


@pytest.mark.parametrize("m_c", M_C)
def test_identities_hold_to_the_last_digits(m_c: float) -> None:
    """sn² + cn² = 1 and dn² + m sn² = 1 on [−K, K] (cn ≥ 0 there), and the parity."""
    K = el.complete_k(m_c)
    half = np.linspace(0.0, K, 101)
    r = np.concatenate((-half[::-1], half))
    sn, cn, dn = el.jacobi_reduced(r, m_c)
    assert np.all(cn >= -2 * EPS) and np.all(dn > 0.0)
    assert np.max(np.abs(sn * sn + cn * cn - 1.0)) < 4 * EPS
    assert np.max(np.abs(dn * dn + (1.0 - m_c) * sn * sn - 1.0)) < 4 * EPS
    assert np.array_equal(sn[::-1], -sn) and np.array_equal(cn[::-1], cn)


@pytest.mark.parametrize("m_c", M_C[1:])
def test_small_values_near_k_keep_their_relative_precision(m_c: float) -> None:
    """sn(K − v) = cn v/dn v, cn(K − v) = √m_c sn v/dn v, dn(K − v) = √m_c/dn v (DLMF 22.4.3).

    cn and dn are tiny near K when m → 1 (√m_c down to 1e-150). K − v is exact for v ≤ K/2
    (Sterbenz) but K itself is known to ulp(K), so the left side is good to ~K/v ulp, and
    dn v ~ sech v on the right to ~v ulp.
    """
    K = el.complete_k(m_c)
    v = np.linspace(0.05, 0.5, 10) * K
    s_v, c_v, d_v = el.jacobi_reduced(v, m_c)
    s_k, c_k, d_k = el.jacobi_reduced(K - v, m_c)
    root = np.sqrt(m_c)
    rtol = 16 * EPS * (1.0 + K / v + v)
    for ours, expected in ((s_k, c_v / d_v), (c_k, root * s_v / d_v), (d_k, root / d_v)):
        assert np.all(np.abs(ours / expected - 1.0) <= rtol)


def test_separatrix_limit() -> None:
    """m_c = 0: tanh and sech; m_c = 1e-300 agrees with them while u ≪ K ≈ 347."""
    u = np.linspace(-30.0, 30.0, 61)
    for m_c in (0.0, 1e-300):
        sn, cn, dn = el.jacobi_reduced(u, m_c)
        np.testing.assert_allclose(sn, np.tanh(u), rtol=8 * EPS, atol=0.0)
        np.testing.assert_allclose(cn, 1.0 / np.cosh(u), rtol=64 * EPS * 30, atol=0.0)  # conditioning |u|
        np.testing.assert_allclose(dn, 1.0 / np.cosh(u), rtol=64 * EPS * 30, atol=0.0)


def test_addition_theorem() -> None:
    """sn(u + v) = (sn u cn v dn v + sn v cn u dn u) / (1 − m sn²u sn²v) (DLMF 22.8.1)."""
    rng = np.random.default_rng(0)
    for m_c in (0.7, 1e-3, 1e-9):
        m = 1.0 - m_c
        u, v = rng.uniform(-3.0, 3.0, (2, 200))
        su, cu, du = el.jacobi(u, m_c)
        sv, cv, dv = el.jacobi(v, m_c)
        s_sum, _, _ = el.jacobi(u + v, m_c)
        expected = (su * cv * dv + sv * cu * du) / (1.0 - m * su * su * sv * sv)
        assert np.max(np.abs(s_sum - expected)) < 1e-13


def test_complete_k_limits_and_agm() -> None:
    """K(0) = π/2; K = π / (2 AGM(1, √m_c)) (an AGM written here); K → ln(4/√m_c) as m_c → 0."""
    assert el.complete_k(1.0) == pytest.approx(0.5 * np.pi, rel=EPS)
    for m_c in M_C:
        a, b = 1.0, np.sqrt(m_c)
        for _ in range(60):
            a, b = 0.5 * (a + b), np.sqrt(a * b)
        assert el.complete_k(m_c) == pytest.approx(0.5 * np.pi / a, rel=8 * EPS)
    for m_c in (1e-20, 1e-100, 1e-300):  # K − ln(4/√m_c) = O(m_c ln m_c)
        assert el.complete_k(m_c) == pytest.approx(np.log(4.0 / np.sqrt(m_c)), rel=4 * EPS)


@pytest.mark.parametrize("m_c", M_C)
def test_elliptic_f_inverts_the_jacobi_functions(m_c: float) -> None:
    """F(am u) = u from (sn u, cn u, dn u) for u ∈ [−K, K]: the round trip the rotor makes."""
    K = el.complete_k(m_c)
    u = np.linspace(-K, K, 101)
    back = el.elliptic_f(*el.jacobi_reduced(u, m_c))
    assert np.max(np.abs(back - u)) <= 16 * EPS * K


def test_elliptic_f_equals_scipy_where_scipy_is_accurate() -> None:
    beta = np.linspace(-7.0, 7.0, 57)
    for m in (0.0, 0.3, 0.9, 0.999):
        np.testing.assert_allclose(el.elliptic_f_angle(beta, 1.0 - m), special.ellipkinc(beta, m),
                                   rtol=1e-14, atol=1e-15)


@pytest.mark.parametrize("n", [-0.3, -3.0, -40.0])
@pytest.mark.parametrize("m_c", [0.6, 1e-4, 1e-12])
def test_third_kind_is_the_integral_of_its_derivative(n: float, m_c: float) -> None:
    """Π − F at am u equals ∫₀ᵘ n sn²/(1 − n sn²) du (scipy quad over our sn); complete value at K."""
    K = el.complete_k(m_c)
    for u in (0.3, 0.5 * K, 0.9 * K, K):
        sn, cn, dn = el.jacobi_reduced(u, m_c)
        value = el.third_kind_minus_f(sn, cn, dn, n)

        def rate(v: float) -> float:
            s = el.jacobi_reduced(v, m_c)[0]
            return n * s * s / (1.0 - n * s * s)

        expected = quad(rate, 0.0, u, epsabs=1e-15, epsrel=1e-13, limit=200)[0]
        assert value == pytest.approx(expected, rel=1e-12, abs=1e-14)
    assert el.third_kind_minus_f(1.0, 0.0, np.sqrt(m_c), n) == pytest.approx(el.third_kind_minus_f_complete(n, m_c),
                                                                            rel=4 * EPS)


def test_third_kind_at_m_zero_is_elementary() -> None:
    """m = 0: Π(n; β | 0) = atan(√(1 − n) tan β)/√(1 − n), F = β (DLMF 19.6.12)."""
    beta = np.linspace(-1.5, 1.5, 31)
    for n in (-0.5, -2.0, 0.5):
        s, c = np.sin(beta), np.cos(beta)
        root = np.sqrt(1.0 - n)
        expected = np.arctan(root * np.tan(beta)) / root - beta
        np.testing.assert_allclose(el.third_kind_minus_f(s, c, np.ones_like(s), n), expected, rtol=1e-14, atol=1e-15)


def test_error_free_products_are_exact() -> None:
    """two_product and two_sum lose nothing; c x² − d y² is right to a few ulp of itself plus a
    few ulp² of its terms (a double-double), however much the two terms cancel."""
    rng = np.random.default_rng(1)
    a, b = rng.uniform(-1.0, 1.0, (2, 500)) * 2.0 ** rng.integers(-40, 40, (2, 500))
    p, e = el.two_product(a, b)
    s, f = el.two_sum(a, b)
    for i in range(500):
        assert Fraction(p[i]) + Fraction(e[i]) == Fraction(a[i]) * Fraction(b[i])
        assert Fraction(s[i]) + Fraction(f[i]) == Fraction(a[i]) + Fraction(b[i])
    # The separatrix combination (I3 − I2)/I3 · L3² − (I2 − I1)/I1 · L1² at and near zero.
    c, d = 1.0 / 3.0, 1.0
    y = rng.uniform(0.1, 1.0, 300)
    x = y * np.sqrt(d / c) * (1.0 + rng.choice([0.0, 1e-15, -1e-12, 1e-8], 300))
    got = el.difference_of_products(c, x, d, y)
    for i in range(300):
        exact = Fraction(c) * Fraction(x[i]) ** 2 - Fraction(d) * Fraction(y[i]) ** 2
        terms = Fraction(c) * Fraction(x[i]) ** 2 + Fraction(d) * Fraction(y[i]) ** 2
        assert abs(Fraction(got[i]) - exact) <= 4 * EPS * abs(exact) + 4 * EPS**2 * terms
