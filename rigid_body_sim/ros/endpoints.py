"""The node's per-body endpoints as one object: state publishers, wrench/impulse inputs, IMU
publishers and set_state inputs, with one prepare / commit / release over the four families.
The inputs also have shared topics (``wrench``, ``impulse``, ``set_state``: three subscriptions
for all bodies); the per-body ones exist only if :func:`per_body_inputs` says so.

A change of bodies (start-up, a new scene, a spawn or delete, a change of ``publish_odometry``,
a reset) is made in three moves: :meth:`BodyEndpoints.prepare` creates whatever the new scene
needs beyond what exists, without the session's lock; :meth:`BodyEndpoints.commit` swaps it in
under the lock; :meth:`BodyEndpoints.release` destroys what was replaced, after the lock. The
ticks so wait only for the swap. :class:`BodyEndpoints` is also the session's edge
(:class:`~rigid_body_sim.ros.session.BodyIO`): it takes the arrived inputs for a tick and
publishes (and records) the state after it, with the markers and, where tf2_msgs is importable,
``/tf`` (tf.py; its latched ``/tf_static`` is sent again whenever the scene changes).

Every frame id written or accepted carries the node's ``frame_prefix`` (``""``: none).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ContextManager, Mapping

from rclpy.node import Node
from rclpy.qos import QoSProfile

from ..core import Scene, Simulator
from ..core.imu import ImuSample
from ..offline.recording import McapRecorder
from .contact_wrench import ContactWrenchPublishers
from .contacts import ContactPublisher
from .conversions import time_msg_from_seconds
from .imu import ImuChange, ImuPublishers
from .inputs import InputChange, WrenchInputs
from .markers import MarkerPublisher
from .node_recording import NodeRecording
from .publishers import PublisherChange, StatePublishers
from .session import physics_dt
from .set_state import SetStateChange, SetStateInputs
from .tf import TF_AVAILABLE, TfPublisher

__all__ = ["BodyEndpoints", "EndpointChange", "per_body_inputs"]


def per_body_inputs(settings: Mapping[str, Any]) -> bool:
    """Whether the node subscribes to B/wrench, B/impulse and B/set_state per body: the
    ``per_body_inputs`` parameter, whose ``"auto"`` (the default) follows ``per_body_topics``."""
    choice = settings.get("per_body_inputs", "auto")
    return bool(settings["per_body_topics"]) if choice == "auto" else choice == "true"


@dataclass
class EndpointChange:
    """A prepared change of all four families, and whether the state of the bodies kept stays."""

    publishers: PublisherChange
    inputs: InputChange
    imus: ImuChange
    set_state: SetStateChange
    keep_state: bool
    scene: Scene | None = None


class BodyEndpoints:
    """The four per-body endpoint families of ``node``, the markers, and the recording of what they carry.

    Parameters
    ----------
    node : rclpy.node.Node
        Owner of the endpoints.
    qos : QoSProfile
        Of subscriptions, IMU and marker publishers (state publishers: publishers.STATE_QOS).
    settings : mapping
        ``world_frame``, ``frame_prefix``, ``per_body_topics``, ``per_body_inputs``, ``twist_stamped``
        (fixed for the node's life).
    recording : NodeRecording
        Where published state, wrenches and IMU samples are recorded (if it records).
    """

    def __init__(self, node: Node, qos: QoSProfile, settings: Mapping[str, Any], recording: NodeRecording):
        world_frame, prefix = settings["world_frame"], settings.get("frame_prefix", "")
        self._prefix = prefix
        self.outputs = StatePublishers(node, prefix + world_frame, per_body_topics=settings["per_body_topics"],
                                       twist_stamped=settings["twist_stamped"], frame_prefix=prefix)
        per_body = per_body_inputs(settings)
        self.inputs = WrenchInputs(node, qos, world_frame, prefix, per_body=per_body)
        self.imus = ImuPublishers(node, qos, prefix)
        self.set_state = SetStateInputs(node, qos, world_frame, self.inputs, prefix, per_body=per_body)
        self.markers = MarkerPublisher(node, qos, prefix + world_frame)
        self.contacts = ContactPublisher(node, qos, prefix + world_frame)  # contacts.py
        self.contact_wrenches = ContactWrenchPublishers(node, qos, prefix,  # contact_wrench.py
                                                        bool(settings.get("publish_contact_wrench", False)))
        self.tf = TfPublisher(node, world_frame, prefix) if TF_AVAILABLE else None
        self._tf_scene: Scene | None = None  # the scene whose /tf_static was sent last
        self._tf_scene_due: Scene | None = None  # a committed scene whose /tf_static is still to send
        self._tf_time: float | None = None  # sim time of the last /tf message
        self.recording = recording
        recording.offered_qos = self.outputs.offered_qos()  # qos_overrides applied: what recordings declare

    # ------------------------------------------------------------------ prepare / commit / release

    def prepare(self, scene: Scene, publish_odometry: bool, *, keep_state: bool) -> EndpointChange:
        """Create what ``scene`` needs beyond what exists; touches nothing the ticks read. With
        ``keep_state`` the bodies kept keep their holds, pending impulses and set_states and the
        IMUs kept their noise state (spawn, delete, odometry on/off); without, all start afresh."""
        return EndpointChange(self.outputs.prepare(scene.body_names, publish_odometry), self.inputs.prepare(scene),
                              self.imus.prepare(scene, keep_state=keep_state),
                              self.set_state.prepare(scene.body_names), keep_state, scene)

    def commit(self, change: EndpointChange) -> None:
        """Swap in a prepared change (hold the session's lock)."""
        self.outputs.commit(change.publishers)
        self.inputs.commit(change.inputs, keep_holds=change.keep_state)
        self.imus.commit(change.imus)
        self.set_state.commit(change.set_state)
        if not change.keep_state:
            self.set_state.clear()
        if change.scene is not None and change.scene is not self._tf_scene:
            self._tf_scene_due = change.scene  # sent with the next publish, at the sim time then

    def release(self, change: EndpointChange) -> None:
        """Destroy the endpoints ``change`` replaced (after :meth:`commit`, without the lock)."""
        self.outputs.release(change.publishers)
        self.inputs.release(change.inputs)
        self.imus.release(change.imus)
        self.set_state.release(change.set_state)

    # ------------------------------------------------------------------ per tick (the session's lock held)

    def take_set_states(self, sim: Simulator) -> bool:
        """Apply the set_states that arrived; True if any body was set."""
        return bool(self.set_state.apply(sim))

    def take_wrenches(self, sim: Simulator, wrench_timeout: float) -> None:
        """Hand held wrenches and pending impulses to ``sim``; record them with the scripted ones."""
        held = self.inputs.apply(sim, wrench_timeout)
        self.contact_wrenches.before_tick(sim)
        self.recording.write(lambda recorder: recorder.write_wrenches(sim.time, self._prefixed(
            held + sim.active_scripted_wrenches())))

    def _prefixed(self, wrenches: list[tuple[str, str, Any, Any]]) -> list[tuple[str, str, Any, Any]]:
        """(body, frame, force, torque) with the frame as the node's inputs name it (``"world"``, the
        recorder's world frame, is prefixed by it)."""
        if not self._prefix:
            return wrenches
        return [(body, frame if frame == "world" else self._prefix + frame, force, torque)
                for body, frame, force, torque in wrenches]

    def publish_tick(self, sim: Simulator, tick_s: float, settings: Mapping[str, Any]) -> None:
        """Sample and publish the IMUs due, then the state and the contacts (all recorded if recording)."""
        self.imus.publish(sim, tick_s, self._record_imu if self.recording.recorder is not None else None)
        self.publish(sim, settings)
        self.contact_wrenches.publish(sim, bool(settings.get("publish_contact_wrench", False)))
        contacts = self.contacts.publish(sim)
        if contacts is not None and self.recording.recorder is not None:
            data = self.contacts.cdr(contacts)
            self.recording.write(lambda recorder: recorder.write_contacts(sim.time, data))

    def publish(self, sim: Simulator, settings: Mapping[str, Any]) -> None:
        """Publish the state (and /clock), /tf, the markers when due, and record the state."""
        self.outputs.publish(sim, settings["publish_clock"])
        self._publish_tf(sim)
        self.markers.publish(sim, settings["marker_rate_hz"], lambda: self.inputs.snapshot()[0],
                             settings["marker_force_scale"] if settings["marker_wrenches"] else None,
                             contact_force_scale=settings["marker_force_scale"])
        if self.recording.recorder is not None:
            self.record_state(sim, settings)

    def publish_bodies(self, sim: Simulator) -> None:
        """Publish the bodies' state (and their /tf) only (no /clock, markers or recording)."""
        self.outputs.publish(sim, False)
        self._publish_tf(sim)

    def _publish_tf(self, sim: Simulator) -> None:
        """/tf_static if the scene changed since it was last sent, then /tf (only while subscribed),
        never twice at one sim time: tf2 drops a transform at a stamp it has (TF_REPEATED_DATA) and
        warns, so a republish at the same time (a spawn, a reset_world, a set_state while paused)
        shows on /tf from the next tick on."""
        if self.tf is None:
            return
        stamp = None
        if self._tf_scene_due is not None:
            stamp = time_msg_from_seconds(sim.time)
            self.tf.set_scene(sim, stamp)
            self._tf_scene, self._tf_scene_due = self._tf_scene_due, None
        if sim.time != self._tf_time and self.tf.has_subscribers():
            self.tf.publish(sim, stamp or time_msg_from_seconds(sim.time))
            self._tf_time = sim.time

    def record_state(self, sim: Simulator, settings: Mapping[str, Any]) -> None:
        """Write the state just published, then /clock: with ``per_body_topics`` false the two
        batches as published (two messages a tick for all bodies), else each running body's
        pose and twist."""
        batches = self.outputs.last_batches_cdr()
        if not settings["per_body_topics"] and batches is not None and batches[0] is sim.body_names:
            self.recording.write(lambda recorder: (recorder.write_batches(*batches), recorder.write_clock(sim.time)))
            return
        finite = sim.state.finite_bodies().tolist()
        skip = [body for index, body in enumerate(sim.body_names) if not finite[index]]
        self.recording.write(lambda recorder: recorder.write_simulator(sim, skip=skip))

    def open_recorder(self, path: str, sim: Simulator, settings: Mapping[str, Any]) -> McapRecorder:
        """A new recorder at ``path`` for a change to ``settings``, starting from ``sim``'s state.

        Raises
        ------
        OSError
            If ``path`` cannot be written.
        """
        return self.recording.open(path, sim, dt=physics_dt(settings), integrator=settings["integrator"])

    def replace_recorder(self, recorder: McapRecorder | None) -> McapRecorder | None:
        """Record from now on with ``recorder`` (None: stop); returns the one replaced (hold the lock)."""
        return self.recording.replace(recorder)

    def finish_recorder(self, recorder: McapRecorder) -> None:
        """Finish a replaced recorder: a complete, indexed file (without the lock)."""
        self.recording.finish(recorder)

    def start_recording(self, path: str, sim: Simulator, lock: ContextManager[Any]) -> None:
        """Record to ``path`` from ``sim``'s state on, unless recording already.

        Raises
        ------
        ValueError
            If ``path`` cannot be written.
        """
        if path and self.recording.recorder is None:
            try:
                recorder = self.recording.open(path, sim)
            except OSError as exc:
                raise ValueError(f"record_path rejected: cannot record to {path!r} ({exc})") from exc
            with lock:
                self.recording.replace(recorder)

    def stop_recording(self, lock: ContextManager[Any]) -> None:
        """Finish the recording (a complete, indexed MCAP file); ``lock`` is held while it is taken
        away from the ticks (``contextlib.nullcontext()`` for an exit that cannot wait for a stuck tick)."""
        with lock:
            recorder = self.recording.replace(None)
        if recorder is not None:
            self.recording.finish(recorder)

    def _record_imu(self, sample: ImuSample) -> None:
        self.recording.write(lambda recorder: recorder.write_imu(
            sample.time, sample.site, sample.orientation_xyzw, sample.angular_velocity, sample.specific_force,
            sample.covariances))
