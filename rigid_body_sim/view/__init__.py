"""A live 3D view of a running ``rigid_body_sim_node`` in the browser (``rigid-body-sim view``).

A client of the node's public ROS interface only: it joins the ROS domain as its own rclpy node,
reads ``poses`` (with the node's ``body_names`` parameter) and ``markers``, calls ``~/set_paused``,
``~/step`` and ``~/reset``, and publishes ``B/impulse`` from the "Feel the offset" panel. The page
is served by viser (docs/view.md says why). :mod:`.strike` is the panel's geometry, without ROS or
viser; :mod:`.app` is the server and the drawing of the bodies (:class:`.app.Bodies`); :mod:`.replay`
shows an MCAP recording with that same drawing, a time slider and Play/Pause, without a ROS domain
(``rigid-body-sim view RECORDING``).
"""

from .strike import STRIKE_IMPULSE_NS, strike_point, strike_wrench

__all__ = ["STRIKE_IMPULSE_NS", "strike_point", "strike_wrench"]
