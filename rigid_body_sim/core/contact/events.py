"""A contact event, as the solver records it (:attr:`ContactSolver.events`)."""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["ContactEvent"]


@dataclass(frozen=True)
class ContactEvent:
    """One contact event.

    Attributes
    ----------
    time : float
        s of sim time (located inside the step).
    body : str
    ground : int
        Index into the scene's ``ground`` list.
    kind : str
        ``impact``, ``rest`` (persistent contact from here; for a Zeno sequence, dated at its
        accumulation time), ``lift-off`` or ``stick`` (a sliding contact stopped).
    normal_speed_before, normal_speed_after : float
        Lowest normal velocity of the contact points (m/s, positive away from the ground).
    impulse : float
        Σ normal impulse, N·s (impacts), else 0.
    energy_before, energy_after : float
        Kinetic energy of the body, J, around the event.
    delta_v_world : tuple of 3 floats
        Impacts: the jump of the centre of mass velocity, m/s, world axes; else ().
    delta_w_principal : tuple of 3 floats
        Impacts: the jump of the angular velocity, rad/s, the body's principal axes P; else ().
    q_WP : tuple of 4 floats
        Impacts: the body's orientation at the impact, (w, x, y, z); else ().
    contacts : int
        Impacts: the contact points that took part; else 0.
    restitution_used : float
        Impacts: the restitution factor the impact law applied (below the pair's e when the energy
        cap acted, :mod:`~rigid_body_sim.core.kernels.contact.impacts`); else 0.
    """

    time: float
    body: str
    ground: int
    kind: str
    normal_speed_before: float = 0.0
    normal_speed_after: float = 0.0
    impulse: float = 0.0
    energy_before: float = 0.0
    energy_after: float = 0.0
    delta_v_world: tuple = ()
    delta_w_principal: tuple = ()
    q_WP: tuple = ()
    contacts: int = 0
    restitution_used: float = 0.0
