"""Signed distance and normal of two convex shapes (sphere, box, cylinder, capsule) to ~1e-12, by direct optimisation.

The reference for the narrow phase of pairs with a cylinder (benchmarks/pair_oracle.py,
test/test_exact_convex.py). It shares no code with the compiled narrow phase
(core/kernels/contact/) and uses neither GJK nor EPA.

Definition. For convex A, B and a unit direction u, sep(u) = min_B u·x − max_A u·x. The signed
distance (the distance when apart, minus the penetration depth, i.e. the shortest translation of
B that separates them, when they overlap) is sd = max over unit u of sep(u), and the maximising u
is the normal from A to B. Every shape here is centrally symmetric about its centre c, so
sep(u) = (c_B − c_A)·u − k_A(u) − k_B(u) with the centred support functions

* sphere (radius r): r|u|;
* capsule (radius r, half length h along its axis a): h|a·u| + r|u|;
* box (half extents d_i along its axes e_i): Σ d_i |e_i·u|;
* cylinder (radius r, half length h along its axis a): r|u − (a·u)a| + h|a·u|.

sep is smooth on the unit sphere except on the great circles g·u = 0 of the terms w|g·u| and at
the poles ±a of the cylinders' radial terms. Its maximum is therefore one of

1. a pole ±a, or a point where two of those circles cross (±g₁×g₂/|g₁×g₂|): evaluated directly;
2. a stationary point of sep restricted to one circle (the term of that circle is 0 on it): the
   sign change of the analytic d sep/dθ around every local maximum of sep over 4096 angles, solved
   by ``scipy.optimize.brentq`` (xtol 1e-15), and Newton on the smooth pieces from 1e-3 and
   3e-2 rad off each such point on both sides (a maximum just off a circle);
3. a stationary point of a smooth piece: Newton's method on the sphere (Riemannian gradient and
   Hessian of the piece with the signs fixed; backtracking on the piece's value while the step
   is above 1e-6 rad) from every local maximum of sep over a Fibonacci grid of 6000 directions
   (each compared with its 10 nearest neighbours, scipy's cKDTree), kept as stationary when the
   gradient vanished at a point of the same piece; and from five points next to each pole (1e-4 to
   0.2 rad from it, towards the tangent gradient of the other terms), where the radial term's
   cone makes starts from the grid unreliable.

sd is the largest sep over all candidates (sep evaluated with the full formula, so every candidate
is a lower bound and the answer is attained along the returned u). Values alone cannot place a
smooth maximum closer than ~1e-8 rad (sep is flat to second order there), so among candidates
equal to the largest within round-off (1e-14 × the sizes) the most precise kind wins: a
stationary point inside a smooth piece, then one on a circle, then a pole or crossing, then a
sample. Apart, sep is concave on the ball and the maximum is unique; overlapping, it can have
several local maxima, all of which the enumeration visits. ``certified`` reports that no
direction within 1e-3 rad (400 random directions at radii 1e-8 to 1e-3) separates more than
sd + 1e-13 × the size.

Shapes are given as ``(kind, dims, centre (3,), R_WS (3, 3))`` with kind one of "sphere", "box",
"cylinder", "capsule" and dims as in a shape row (sphere r; box half extents; cylinder and
capsule r, half length), lengths in m, world frame.
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np
from scipy.optimize import brentq
from scipy.spatial import cKDTree

__all__ = ["signed_distance", "sep"]

_KINDS = ("sphere", "box", "cylinder", "capsule")
_GRID = 6000
_NEIGHBOURS = 10
_CIRCLE_SAMPLES = 4096


def _check(shape, name):
    try:
        kind, dims, centre, rot = shape
    except (TypeError, ValueError):
        raise ValueError(f"{name}: expected (kind, dims, centre (3,), R_WS (3, 3)), got {shape!r}") from None
    if kind not in _KINDS:
        raise ValueError(f"{name}: expected a kind in {_KINDS}, got {kind!r}")
    dims = np.asarray(dims, float).reshape(-1)
    centre = np.asarray(centre, float).reshape(3)
    rot = np.asarray(rot, float).reshape(3, 3)
    if not (np.all(np.isfinite(dims)) and np.all(dims >= 0.0)):
        raise ValueError(f"{name}: expected finite dimensions ≥ 0, got {dims!r}")
    if np.max(np.abs(rot.T @ rot - np.eye(3))) > 1e-12:
        raise ValueError(f"{name}: expected a rotation matrix R_WS, got {rot!r}")
    return kind, dims, centre, rot


class _Terms:
    """sep(u) of a pair as a list of terms: abs terms w|g·u|, radial terms r|u − (a·u)a|, a margin m|u|."""

    def __init__(self, a, b):
        self.offset = b[2] - a[2]
        self.abs_w, self.abs_g = [], []
        self.rad_w, self.rad_a = [], []
        self.margin = 0.0
        for kind, d, _, rot in (a, b):
            if kind == "sphere":
                self.margin += d[0]
            elif kind == "capsule":
                self.margin += d[0]
                self.abs_w.append(d[1])
                self.abs_g.append(rot[:, 2])
            elif kind == "box":
                for i in range(3):
                    self.abs_w.append(d[i])
                    self.abs_g.append(rot[:, i])
            else:
                self.rad_w.append(d[0])
                self.rad_a.append(rot[:, 2])
                self.abs_w.append(d[1])
                self.abs_g.append(rot[:, 2])
        self.abs_w, self.abs_g = np.array(self.abs_w), np.array(self.abs_g).reshape(-1, 3)
        self.rad_w, self.rad_a = np.array(self.rad_w), np.array(self.rad_a).reshape(-1, 3)
        self.scale = max(1e-300, float(np.max(np.concatenate((self.abs_w, self.rad_w, [self.margin])))))

    def value(self, u):
        """sep at the directions u (k, 3), each of any length (sep is positively homogeneous)."""
        u = np.atleast_2d(u)
        v = u @ self.offset - self.margin * np.linalg.norm(u, axis=1)
        if len(self.abs_w):
            v = v - np.abs(u @ self.abs_g.T) @ self.abs_w
        for w, a in zip(self.rad_w, self.rad_a):
            t = u @ a
            v = v - w * np.linalg.norm(u - t[:, None] * a, axis=1)
        return v

    def piece(self, u, signs):
        """The smooth piece with abs signs ``signs`` at the unit u (equal to sep where those signs hold)."""
        v = u @ self.offset - self.margin - (signs * self.abs_w) @ (self.abs_g @ u)
        for w, a in zip(self.rad_w, self.rad_a):
            v -= w * np.linalg.norm(u - (u @ a) * a)
        return v

    def derivatives(self, u, signs):
        """Gradient (3,) and Hessian (3, 3) of the smooth piece with abs signs ``signs`` at unit u (margin term omitted)."""
        g = self.offset - (signs * self.abs_w) @ self.abs_g
        h = np.zeros((3, 3))
        for w, a in zip(self.rad_w, self.rad_a):
            p = u - (u @ a) * a
            norm = np.linalg.norm(p)
            if norm == 0.0:
                return None, None
            proj = np.eye(3) - np.outer(a, a)
            g = g - w * p / norm
            h = h - w * (proj - np.outer(p, p) / norm**2) / norm
        return g, h


def sep(a, b, u):
    """sep(u) = min_B u·x − max_A u·x (m) at the unit directions u (k, 3) for shapes a, b (see the module docstring)."""
    return _Terms(_check(a, "a"), _check(b, "b")).value(np.asarray(u, float))


@lru_cache(maxsize=1)
def _grid():
    """A Fibonacci grid of unit directions and the indices of each one's nearest neighbours."""
    k = np.arange(_GRID) + 0.5
    z = 1.0 - 2.0 * k / _GRID
    phi = math.pi * (1.0 + math.sqrt(5.0)) * k
    rho = np.sqrt(1.0 - z * z)
    u = np.stack((rho * np.cos(phi), rho * np.sin(phi), z), axis=1)
    _, idx = cKDTree(u).query(u, _NEIGHBOURS + 1)
    return u, idx[:, 1:]


def _basis(u):
    """Two unit vectors completing u to an orthonormal basis."""
    t = np.array([1.0, 0.0, 0.0]) if abs(u[0]) < 0.6 else np.array([0.0, 1.0, 0.0])
    t1 = t - (t @ u) * u
    t1 /= np.linalg.norm(t1)
    return t1, np.cross(u, t1)


def _newton_piece(terms, u):
    """Newton's method on the smooth piece of sep containing u (abs signs fixed at u).

    Returns (u, stationary): stationary when the tangent gradient vanished to round-off at a point
    of that same piece (a local maximum of sep inside it). Backtracking on the piece's value only
    while the step is above 1e-6 rad: closer, values differ by less than round-off and only the
    gradient can tell the optimum.
    """
    signs = np.sign(terms.abs_g @ u) if len(terms.abs_w) else np.zeros(0)
    converged = False
    for _ in range(40):
        g, h = terms.derivatives(u, signs)
        if g is None:
            return u, False
        t1, t2 = _basis(u)
        tb = np.stack((t1, t2), axis=1)
        grad = tb.T @ g
        hess = tb.T @ (h - (u @ g) * np.eye(3)) @ tb
        if np.linalg.norm(grad) <= 1e-16 * terms.scale:
            converged = True
            break
        try:
            step = -np.linalg.solve(hess, grad)
        except np.linalg.LinAlgError:
            return u, False
        if step @ grad <= 0.0:  # not an ascent direction: the gradient instead
            step = grad / np.max(np.abs(np.linalg.eigvalsh(hess)))
        if np.linalg.norm(step) > 0.3:
            step = 0.3 * step / np.linalg.norm(step)
        if np.linalg.norm(step) > 1e-6:
            here = terms.piece(u, signs)
            for _ in range(20):
                w = u + tb @ step
                w /= np.linalg.norm(w)
                if terms.piece(w, signs) >= here:
                    break
                step = 0.5 * step
            else:
                return u, False
        else:
            w = u + tb @ step
            w /= np.linalg.norm(w)
        u = w
        if np.linalg.norm(step) <= 1e-15:
            converged = True
            break
    inside = len(signs) == 0 or bool(np.all(np.sign(terms.abs_g @ u) == signs))
    negative = np.all(np.linalg.eigvalsh(hess) < 0.0)
    return u, bool(converged and inside and negative)


def _circle_candidates(terms, g, out):
    """Stationary points of sep on the great circle g·u = 0, appended to out as (u, rank): roots 2, samples 0."""
    p, q = _basis(g / np.linalg.norm(g))
    theta = np.linspace(0.0, 2.0 * math.pi, _CIRCLE_SAMPLES, endpoint=False)

    def at(t):
        return np.cos(t)[..., None] * p + np.sin(t)[..., None] * q

    def slope(t):  # d sep/dθ of the piece at θ (analytic; the circle's own term is 0 along it)
        u = at(np.array(t))
        g, _ = terms.derivatives(u, np.sign(terms.abs_g @ u))
        if g is None:
            return math.nan
        return float(g @ (-math.sin(t) * p + math.cos(t) * q))

    values = terms.value(at(theta))
    # local maxima of the sampled values, then the sign change of the slope around each
    nxt, prv = np.roll(values, -1), np.roll(values, 1)
    for k in np.nonzero((values >= nxt) & (values >= prv))[0]:
        lo, hi = theta[k] - 2 * math.pi / _CIRCLE_SAMPLES, theta[k] + 2 * math.pi / _CIRCLE_SAMPLES
        out.append((at(np.array(theta[k])), 0))
        try:
            s_lo, s_hi = slope(lo), slope(hi)
            if s_lo > 0.0 > s_hi:
                t = brentq(slope, lo, hi, xtol=1e-15, rtol=4 * np.finfo(float).eps)
                u = at(np.array(t))
                out.append((u, 2))
                # a maximum just off the circle, inside a smooth piece: Newton from both sides
                gn = g / np.linalg.norm(g)
                for delta in (-3e-2, -1e-3, 1e-3, 3e-2):
                    w, stationary = _newton_piece(terms, (u + delta * gn) / math.hypot(1.0, delta))
                    out.append((w, 3 if stationary else 0))
        except ValueError:
            pass


def signed_distance(a, b):
    """(sd (m), n (3,) unit from A to B, certified) of shapes a, b: see the module docstring."""
    a, b = _check(a, "a"), _check(b, "b")
    terms = _Terms(a, b)
    cands = []  # (u, rank): 3 a stationary point inside a smooth piece, 2 on a circle, 1 a kink point, 0 a sample
    # 1. poles and crossings of kink circles
    for axis in terms.rad_a:
        cands += [(axis, 1), (-axis, 1)]
    gs = list(terms.abs_g)
    for i in range(len(gs)):
        for j in range(i + 1, len(gs)):
            c = np.cross(gs[i], gs[j])
            if np.linalg.norm(c) > 1e-12:
                c = c / np.linalg.norm(c)
                cands += [(c, 1), (-c, 1)]
    # 2. stationary points on each circle (parallel axes give one circle twice: skip repeats)
    seen = []
    for g in gs:
        if any(abs(abs(g @ s) - 1.0) < 1e-15 for s in seen):
            continue
        seen.append(g)
        _circle_candidates(terms, g, cands)
    # 3. smooth pieces from the local maxima of the grid
    grid, nbr = _grid()
    values = terms.value(grid)
    is_max = np.all(values[:, None] >= values[nbr], axis=1)
    for k in np.nonzero(is_max)[0]:
        cands.append((grid[k], 0))
        u, stationary = _newton_piece(terms, grid[k])
        cands.append((u, 3 if stationary else 0))
    # 4. next to each pole: the cone of the radial term makes Newton from the grid unreliable there;
    # starts along the tangent gradient of the other terms (where the maximum leaves the pole)
    for w, axis in zip(terms.rad_w, terms.rad_a):
        for pole in (axis, -axis):
            signs = np.sign(terms.abs_g @ pole)
            rest = terms.offset - (signs * terms.abs_w) @ terms.abs_g
            for w2, a2 in zip(terms.rad_w, terms.rad_a):
                p2 = pole - (pole @ a2) * a2
                if np.linalg.norm(p2) > 1e-12:
                    rest = rest - w2 * p2 / np.linalg.norm(p2)
            t = rest - (rest @ pole) * pole
            if np.linalg.norm(t) <= w:  # the cone wins: the pole itself is a local maximum
                continue
            t /= np.linalg.norm(t)
            for theta in (1e-4, 1e-3, 1e-2, 0.05, 0.2):
                u, stationary = _newton_piece(terms, math.cos(theta) * pole + math.sin(theta) * t)
                cands.append((u, 3 if stationary else 0))
    dirs = np.array([c[0] for c in cands])
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    ranks = np.array([c[1] for c in cands])
    vals = terms.value(dirs)
    # the largest sep; among candidates equal to it within round-off, the most precise kind (values
    # cannot tell directions apart closer than ~1e-8 rad: sep is flat to second order there)
    tie = 1e-14 * (terms.scale + np.linalg.norm(terms.offset))
    near = vals >= np.max(vals) - tie
    rank = np.max(ranks[near])
    pick = np.nonzero(near & (ranks == rank))[0]
    best = int(pick[np.argmax(vals[pick])])
    sd, n = float(vals[best]), dirs[best]
    # local certificate: no nearby direction separates more
    rng = np.random.default_rng(0)
    t1, t2 = _basis(n)
    ang = rng.uniform(0.0, 2 * math.pi, 400)
    rad = 10.0 ** rng.uniform(-8.0, -3.0, 400)
    probe = n + (np.cos(ang) * rad)[:, None] * t1 + (np.sin(ang) * rad)[:, None] * t2
    probe /= np.linalg.norm(probe, axis=1, keepdims=True)
    certified = bool(np.max(terms.value(probe)) <= sd + 1e-13 * terms.scale)
    return sd, n, certified
