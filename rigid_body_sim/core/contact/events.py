"""A contact event, as the solver records it (:attr:`ContactSolver.events`), and the limit on a Zeno sequence of them
(the ground pass, solver.py, and a group's step between bodies, body_pairs.py)."""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["ContactEvent", "ZENO_IMPACTS"]

#: Impacts of a body in flight within one step after which the sequence is taken as Zeno's and the body rests where
#: the last one left it: a can spinning with its rim on a wall rolls on it while its contact points accelerate away
#: from it, so that no rebound's apex falls below ZENO_APEX (solver.py), and its impacts came ever closer in time.
ZENO_IMPACTS = 100


@dataclass(frozen=True)
class ContactEvent:
    """One contact event.

    Attributes
    ----------
    time : float
        s of sim time (located inside the step).
    body : str
    ground : int
        Index into the solver's plane rows (the scene's ``ground`` list first, then static shapes'
        planes: ContactSolver.static_body_of); -1 for an impact with another moving body.
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
    other : str
        An impact between two moving bodies (body_pairs.py): the other body's name (it has an
        event of its own at the same time, naming this one); else "". Then ``normal_speed_*``
        are the relative normal velocity of the pair (m/s), ``impulse`` the normal impulse
        between them, ``energy_*`` the kinetic energy of both, ``contacts`` the pair's contact points.
    point_world : tuple of 3 floats
        Between two bodies: the mean of the contact points (world, m); else ().
    normal_world : tuple of 3 floats
        Between two bodies: the unit contact normal, world axes, from the other body towards this
        one (the direction of the normal impulse on this body); else ().
    distance : float
        Between two bodies: their signed distance at the located impact (m; round-off of the root); else 0.
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
    other: str = ""
    point_world: tuple = ()
    normal_world: tuple = ()
    distance: float = 0.0
