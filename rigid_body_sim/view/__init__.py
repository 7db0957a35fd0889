"""A live 3D view of a running ``rigid_body_sim_node`` in the browser (``rigid-body-sim view``).

A client of the node's public ROS interface only (:mod:`.client`): it joins the ROS domain as its
own rclpy node, reads ``poses``, ``velocities``, ``markers``, ``contacts`` and the node's
parameters, calls its services, sets ``integrator``, ``rate_hz`` and ``real_time_factor``, and
publishes strikes on ``impulse``. The page is served by viser (docs/view.md says why):
:mod:`.page` is the live page, :mod:`.drawing` the drawing shared with the replay of a recording
(:mod:`.replay`, no ROS), :mod:`.app` the server and the command. Pure parts, without ROS or
viser: :mod:`.strike` (the "Feel the offset" strike), :mod:`.pick` (click-to-strike: where a click
ray meets a shape), :mod:`.mechanics` (the plotted energy and |L|), :mod:`.wire` (``poses`` read
from CDR with numpy).
"""

from .strike import STRIKE_IMPULSE_NS, strike_point, strike_wrench

__all__ = ["STRIKE_IMPULSE_NS", "strike_point", "strike_wrench"]
