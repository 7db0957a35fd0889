"""The node's IMUs: sensor_msgs/Imu on ``<body>/<site>/imu`` for every site with ``imu:`` in the scene.

Each tick, right after its steps, :meth:`ImuPublishers.publish` reads the IMUs that are due
(core/imu.py's :class:`~rigid_body_sim.core.imu.ImuBank`: ideal readings from
``Simulator.site_readings`` under that step's wrenches, plus the declared noise) and publishes
them: header.frame_id ``<body>/<site>``, stamp = the tick's sim time, REP-145 specific force in
``linear_acceleration``, angular velocity in the sensor's axes, the sensor frame's orientation
in ``world_frame``, covariances from the noise parameters (core/imu.py says which).

Publishers change in the three steps of :mod:`.publishers` (prepare, commit, release), so a
scene change or a spawn never holds the tick lock while endpoints are made; an IMU whose site
and spec are unchanged keeps its publisher and its noise state.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable

from rclpy.node import Node
from rclpy.qos import QoSProfile
from sensor_msgs.msg import Imu

from ..core import Scene, Simulator
from ..core.imu import ImuBank, ImuSample
from .conversions import time_msg_from_seconds
from .replaceable import create_replaceable_publisher

__all__ = ["ImuChange", "ImuPublishers", "fill_imu"]


@dataclass
class ImuChange:
    """Prepared IMUs: the bank and publishers to swap in, ``stale`` publishers to destroy after."""

    bank: ImuBank
    publishers: dict[str, Any]
    stale: list[Any]


def fill_imu(msg: Imu, sample: ImuSample, frame_prefix: str = "") -> Imu:
    """Fill ``msg`` from ``sample`` (frame_id = ``frame_prefix`` + the site's name ``<body>/<site>``)."""
    msg.header.stamp = time_msg_from_seconds(sample.time)
    msg.header.frame_id = frame_prefix + sample.site
    o = msg.orientation
    if sample.orientation_xyzw is not None:
        o.x, o.y, o.z, o.w = (float(v) for v in sample.orientation_xyzw)
    else:
        o.x = o.y = o.z = o.w = 0.0
    w, f = msg.angular_velocity, msg.linear_acceleration
    w.x, w.y, w.z = (float(v) for v in sample.angular_velocity)
    f.x, f.y, f.z = (float(v) for v in sample.specific_force)
    msg.orientation_covariance, msg.angular_velocity_covariance, msg.linear_acceleration_covariance = (
        [float(c) for c in cov] for cov in sample.covariances)
    return msg


class ImuPublishers:
    """The IMUs of the node's scene and their publishers.

    Parameters
    ----------
    node : rclpy.node.Node
    qos : QoSProfile
    frame_prefix : str
        In front of every header.frame_id (the node's ``frame_prefix``).
    """

    def __init__(self, node: Node, qos: QoSProfile, frame_prefix: str = ""):
        self._node = node
        self._prefix = frame_prefix
        self._qos = qos
        self.bank = ImuBank({})
        self.publishers: dict[str, Any] = {}
        self._msg = Imu()

    def prepare(self, scene: Scene, *, keep_state: bool = True) -> ImuChange:
        """IMUs of ``scene``: publishers of sites already published kept, new ones created. With
        ``keep_state`` an unchanged IMU keeps its noise state and schedule (spawn, delete);
        without, every IMU starts afresh (a new scene)."""
        bank = ImuBank(scene.imus, self.bank if keep_state else None)
        publishers = {site: self.publishers.get(site)
                      or create_replaceable_publisher(self._node, Imu, f"{site}/imu", self._qos)
                      for site in bank.sites}
        stale = [pub for site, pub in self.publishers.items() if site not in publishers]
        return ImuChange(bank, publishers, stale)

    def commit(self, change: ImuChange) -> None:
        """Swap in prepared IMUs (hold the node's lock)."""
        self.bank, self.publishers = change.bank, change.publishers

    def release(self, change: ImuChange) -> None:
        """Destroy the publishers ``change`` replaced (after :meth:`commit`, without the lock)."""
        for publisher in change.stale:
            self._node.destroy_publisher(publisher)
        change.stale = []

    def publish(self, sim: Simulator, tick_s: float, record: Callable[[ImuSample], None] | None = None) -> None:
        """Sample and publish the IMUs due at ``sim.time`` (right after the tick's steps; hold the
        node's lock). ``tick_s`` is the tick's sim-time length; ``record(sample)`` also records each."""
        if not self.publishers:
            return
        stopped = set(sim.stopped_bodies)
        for sample in self.bank.sample(sim, tick_s):
            if sample.site.split("/", 1)[0] in stopped:
                continue
            self.publishers[sample.site].publish(fill_imu(self._msg, sample, self._prefix))
            if record is not None:
                record(sample)
