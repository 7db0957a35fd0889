"""Closed forms of rigid contact with a flat ground: the bouncing ball, the sliding box, slide to roll, the incline,
the rocking block.

Each is the textbook answer of the rigid model (Newton restitution e, Coulomb friction μ with
one coefficient, point contact, uniform gravity g > 0 along −n). Times in s, lengths in m,
speeds in m/s. Nothing the simulator runs imports this module (see the package docstring):
the contact tests and benchmarks/contact_peers.py compare against it.
"""

from __future__ import annotations

import math

__all__ = [
    "bounce_impact_time",
    "bounce_apex",
    "bounce_impact_speed",
    "bounce_rest_time",
    "sliding_stop",
    "sliding_speed_time",
    "rolling_start",
    "slip_speed_time",
    "incline_acceleration",
    "rocking_spin_kept",
    "rocking_landings",
]


def _positive(name: str, value: float) -> float:
    value = float(value)
    if not (math.isfinite(value) and value > 0.0):
        raise ValueError(f"{name}: expected a finite number > 0, got {value!r}")
    return value


def _restitution(e: float) -> float:
    e = float(e)
    if not 0.0 <= e < 1.0:
        raise ValueError(f"e: expected a restitution in [0, 1), got {e!r}")
    return e


def bounce_impact_time(k: int, h0: float, e: float, g: float) -> float:
    """Time of impact k = 1, 2, ... of a ball released at rest with its lowest point h0 above the ground.

    t₁ = √(2 h0 / g); flight k (after impact k) lasts 2 eᵏ v₁ / g with v₁ = g t₁, so
    t_k = t₁ (1 + 2 e (1 − e^(k−1)) / (1 − e)).
    """
    if int(k) != k or k < 1:
        raise ValueError(f"k: expected an impact number ≥ 1, got {k!r}")
    h0, g, e = _positive("h0", h0), _positive("g", g), _restitution(e)
    t1 = math.sqrt(2.0 * h0 / g)
    return t1 + sum(2.0 * e**j * t1 for j in range(1, int(k)))


def bounce_apex(k: int, h0: float, e: float) -> float:
    """Height of the lowest point at the apex of flight k = 1, 2, ... (after impact k): h0 e^(2k)."""
    if int(k) != k or k < 1:
        raise ValueError(f"k: expected a flight number ≥ 1, got {k!r}")
    return _positive("h0", h0) * _restitution(e) ** (2 * int(k))


def bounce_impact_speed(k: int, h0: float, e: float, g: float) -> float:
    """Approach speed at impact k (> 0): √(2 g h0) e^(k−1)."""
    return math.sqrt(2.0 * _positive("g", g) * _positive("h0", h0)) * _restitution(e) ** (int(k) - 1)


def bounce_rest_time(h0: float, e: float, g: float) -> float:
    """The accumulation time of the infinitely many bounces (Zeno): T = t₁ (1 + e) / (1 − e)."""
    e = _restitution(e)
    return math.sqrt(2.0 * _positive("h0", h0) / _positive("g", g)) * (1.0 + e) / (1.0 - e)


def sliding_stop(v0: float, mu: float, g: float) -> tuple[float, float]:
    """(distance, time) of a body sliding on a face at v0 until friction μ m g stops it: v0²/(2μg), v0/(μg)."""
    v0, mu, g = _positive("v0", v0), _positive("mu", mu), _positive("g", g)
    return v0 * v0 / (2.0 * mu * g), v0 / (mu * g)


def sliding_speed_time(speed: float, v0: float, mu: float, g: float) -> float:
    """When the sliding body's speed has fallen from v0 to ``speed`` (0 ≤ speed ≤ v0): (v0 − speed)/(μg)."""
    if not 0.0 <= speed <= v0:
        raise ValueError(f"speed: expected a speed in [0, v0 = {v0}], got {speed!r}")
    return (v0 - speed) / (_positive("mu", mu) * _positive("g", g))


def rolling_start(v0: float, mu: float, g: float, k2: float = 0.4) -> tuple[float, float]:
    """(time, speed) at which a ball launched sliding at v0 without spin starts to roll.

    ``k2`` is I/(m r²) (0.4: a solid sphere). The slip v − ω r falls at μ g (1 + 1/k2), so
    t = k2 v0 / ((1 + k2) μ g) and v = v0 / (1 + k2) (5/7 v0 for a solid sphere).
    """
    v0, mu, g, k2 = _positive("v0", v0), _positive("mu", mu), _positive("g", g), _positive("k2", k2)
    return k2 * v0 / ((1.0 + k2) * mu * g), v0 / (1.0 + k2)


def slip_speed_time(slip: float, v0: float, mu: float, g: float, k2: float = 0.4) -> float:
    """When that ball's slip speed has fallen from v0 to ``slip`` (0 ≤ slip ≤ v0): (v0 − slip) k2/((1 + k2) μ g)."""
    if not 0.0 <= slip <= v0:
        raise ValueError(f"slip: expected a speed in [0, v0 = {v0}], got {slip!r}")
    return (v0 - slip) * _positive("k2", k2) / ((1.0 + k2) * _positive("mu", mu) * _positive("g", g))


def incline_acceleration(theta: float, mu: float, g: float) -> float:
    """Acceleration down a slope of angle θ (rad) of a body sliding on a face: g (sin θ − μ cos θ), 0 if it holds."""
    theta, mu, g = float(theta), float(mu), _positive("g", g)
    if not 0.0 <= theta < 0.5 * math.pi or not mu >= 0.0:
        raise ValueError(f"theta, mu: expected 0 ≤ θ < π/2 and μ ≥ 0, got {theta!r}, {mu!r}")
    return max(0.0, g * (math.sin(theta) - mu * math.cos(theta)))


def rocking_spin_kept(width: float, height: float) -> float:
    """Share of its spin a rigid block keeps when it lands on its other bottom edge (inelastic, without slip,
    the edge it turned about lifting; the angular momentum about the new edge is kept): 1 − (3/2) sin²α,
    α = atan(width / height) (Housner 1963). Below 0 (a block more than √2 times as wide as tall) it stops."""
    alpha = math.atan(_positive("width", width) / _positive("height", height))
    return 1.0 - 1.5 * math.sin(alpha) ** 2


def _rocking_fall(k: float, alpha: float, tilt: float) -> float:
    """Time from rest tilted by ``tilt`` onto an edge to upright, turning about it: ½ I θ̇² = m g r (cos(α − tilt) −
    cos(α − θ)), k = m g r / I; θ = tilt − v² makes the integrand smooth."""
    from scipy.integrate import quad

    def dt_dv(v: float) -> float:
        if v == 0.0:
            return 2.0 / math.sqrt(2.0 * k * math.sin(alpha - tilt))
        return 2.0 * v / math.sqrt(4.0 * k * math.sin(alpha - tilt + 0.5 * v * v) * math.sin(0.5 * v * v))

    return quad(dt_dv, 0.0, math.sqrt(tilt), epsabs=1e-14, epsrel=1e-12, limit=200)[0]


def rocking_landings(count: int, width: float, height: float, tilt: float, g: float) -> list[float]:
    """Times of the first ``count`` landings of a rigid box (its cross-section width × height about the rocking
    axis, uniform) released at rest tilted by ``tilt`` (rad, 0 < tilt < α) onto a bottom edge, rocking on a flat
    ground without slip: it turns about its edge (I = m (w² + h²)/3, its centre r = ½ √(w² + h²) from it) to
    upright, lands on the other edge keeping :func:`rocking_spin_kept` of its spin, rises to the tilt where that
    spin's energy is spent, falls back, and so on. Each fall by quadrature."""
    width, height, g = _positive("width", width), _positive("height", height), _positive("g", g)
    alpha = math.atan(width / height)
    if not 0.0 < tilt < alpha:
        raise ValueError(f"tilt: expected 0 < tilt < atan(width / height) = {alpha!r}, got {tilt!r}")
    kept = rocking_spin_kept(width, height)
    if kept <= 0.0:
        raise ValueError(f"width, height: expected a block that rocks (width < √2 height), got {width!r}, {height!r}")
    k = g * 0.5 * math.hypot(width, height) / ((width * width + height * height) / 3.0)  # m g r / I
    spin = math.sqrt(2.0 * k * (math.cos(alpha - tilt) - math.cos(alpha)))
    at, times = _rocking_fall(k, alpha, tilt), []
    for _ in range(int(count)):
        times.append(at)
        spin *= kept
        apex = alpha - math.acos(math.cos(alpha) + spin * spin / (2.0 * k))  # where the spin left is spent
        at += 2.0 * _rocking_fall(k, alpha, apex)
    return times
