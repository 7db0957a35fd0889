"""Closed form of one impact between two spheres under the project's two-phase law (reference only).

Spheres a and b (masses m, isotropic moments of inertia I about their centres, radii R) touch
at one point on the line of their centres; n is the unit normal from a to b. With u the
velocity of b's contact point relative to a's (world axes), u_n = u·n < 0 (approaching) and
u_t its part across n:

* compression: normal impulse P_c = −m_n u_n with 1/m_n = 1/m_a + 1/m_b; tangential impulse
  −m_t u_t with 1/m_t = 1/m_a + 1/m_b + R_a²/I_a + R_b²/I_b if it lies in the cone
  |P_t| ≤ μ P_c (the contact sticks), else −μ P_c u_t/|u_t| (it slides throughout: for spheres
  the normal and tangential problems decouple, so the slip keeps its direction);
* restitution: e P_c along n, frictionless (Poisson). Total P = (1 + e) P_c n + P_t on b,
  −P on a; the spins change by (r × P_t)/I with r the contact point from each centre.

Returns the velocities after: (v_a, ω_a, v_b, ω_b), world axes. Never imported by the package.
"""

from __future__ import annotations

import numpy as np


def two_sphere_impact(m_a, I_a, R_a, v_a, w_a, m_b, I_b, R_b, v_b, w_b, n, e, mu):
    n = np.asarray(n, float) / np.linalg.norm(n)
    v_a, w_a, v_b, w_b = (np.asarray(x, float) for x in (v_a, w_a, v_b, w_b))
    r_a, r_b = R_a * n, -R_b * n
    u = (v_b + np.cross(w_b, r_b)) - (v_a + np.cross(w_a, r_a))
    u_n = u @ n
    if u_n >= 0.0:
        raise ValueError(f"the spheres must approach along n (u·n < 0), got u·n = {u_n}")
    u_t = u - u_n * n
    m_n = 1.0 / (1.0 / m_a + 1.0 / m_b)
    m_t = 1.0 / (1.0 / m_a + 1.0 / m_b + R_a ** 2 / I_a + R_b ** 2 / I_b)
    p_c = -m_n * u_n
    p_t = -m_t * u_t
    slip = np.linalg.norm(u_t)
    if np.linalg.norm(p_t) > mu * p_c:
        p_t = -mu * p_c * u_t / slip
    impulse = (1.0 + e) * p_c * n + p_t
    return (v_a - impulse / m_a, w_a - np.cross(r_a, p_t) / I_a,
            v_b + impulse / m_b, w_b + np.cross(r_b, p_t) / I_b)
