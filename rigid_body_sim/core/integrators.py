"""The integrators that are not compiled (numpy/scipy), and the table of all of them.

:data:`INTEGRATORS`, :class:`Method` and :func:`get_integrator` are defined with the compiled
methods, in kernels/integrators.py (its module docstring describes every method); this module
adds the two whose step runs in Python, called by the Simulator body group by body group:
``exact_rotor_splitting`` (the compiled kicks around :func:`~rigid_body_sim.core.free_rotor.exact_rotor`)
and ``reference`` (scipy DOP853 on the compiled right-hand side).
"""

from __future__ import annotations

import numpy as np

from .free_rotor import exact_rotor
from .kernels.contact.stage import held_derivatives
from .kernels.integrators import INTEGRATORS, Method, final_kick, get_integrator, kick_and_drift
from .kernels.layout import INERTIA, Q, STATE_WIDTH, W

__all__ = ["Method", "INTEGRATORS", "get_integrator", "step_exact_rotor_splitting", "step_reference",
           "REFERENCE_RTOL", "REFERENCE_ATOL"]


def step_exact_rotor_splitting(Y: np.ndarray, Ynew: np.ndarray, prm: np.ndarray, wrenches: np.ndarray,
                               bodies: np.ndarray, dt: float) -> None:
    """kick(dt/2) · exact free rotor(dt) · kick(dt/2) for the rows ``bodies`` of Y into Ynew.

    The kicks are the compiled ones of the other splittings; the free rotor is
    :func:`~rigid_body_sim.core.free_rotor.exact_rotor` (numpy, vectorised over bodies).
    """
    kick_and_drift(Y, Ynew, prm, wrenches, bodies, dt)
    rows = Ynew[bodies]
    inertia = prm[bodies, INERTIA:INERTIA + 3]
    q, L = exact_rotor(inertia, rows[:, Q:Q + 4], rows[:, W:W + 3], dt)
    Ynew[bodies, Q:Q + 4] = q
    Ynew[bodies, W:W + 3] = L
    final_kick(Ynew, prm, wrenches, bodies, dt)


#: Default tolerances of the ``reference`` integrator (relative, absolute).
REFERENCE_RTOL = 1e-12
REFERENCE_ATOL = 1e-12


def step_reference(Y: np.ndarray, Ynew: np.ndarray, prm: np.ndarray, wrenches: np.ndarray, bodies: np.ndarray,
                   dt: float, rtol: float = REFERENCE_RTOL, atol: float = REFERENCE_ATOL) -> None:
    """scipy DOP853 over one step of :func:`~rigid_body_sim.core.dynamics.derivative`, rows ``bodies`` of Y into Ynew.

    A body whose wrench row carries a persistent contact (layout.HELD) has its holding force
    found at every evaluation (kernels/contact/stage.held_derivative).

    q is normalised after the step. A body DOP853 gives up on (step size underflow on a
    stiff or exploding body) is left non-finite, so the step checks name it.
    """
    n = len(bodies)
    sub_prm = np.ascontiguousarray(prm[bodies])
    sub_w = np.ascontiguousarray(wrenches[bodies])
    y0 = np.ascontiguousarray(Y[bodies, :STATE_WIDTH])
    rates = np.empty((n, STATE_WIDTH))

    def rhs(_t: float, flat: np.ndarray) -> np.ndarray:
        held_derivatives(flat.reshape(n, STATE_WIDTH), sub_prm, sub_w, rates)
        return rates.ravel().copy()

    from scipy.integrate import solve_ivp  # on first use: its import takes about 0.3 s of every start

    with np.errstate(all="ignore"):
        solution = solve_ivp(rhs, (0.0, dt), y0.ravel(), method="DOP853", rtol=rtol, atol=atol)
    if solution.success:
        end = solution.y[:, -1].reshape(n, STATE_WIDTH)
        end[:, Q:Q + 4] /= np.linalg.norm(end[:, Q:Q + 4], axis=1, keepdims=True)
        Ynew[bodies, :STATE_WIDTH] = end
    elif n == 1:
        Ynew[bodies, :STATE_WIDTH] = np.nan
    else:  # find the body that makes the solver fail: integrate each on its own
        for i in bodies:
            step_reference(Y, Ynew, prm, wrenches, np.array([i]), dt, rtol, atol)
