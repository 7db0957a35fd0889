"""IMU sensor models on sites at run time: the noise added to ideal readings, and the sampler of a simulation.

What a scene declares (:class:`~rigid_body_sim.core.imu_spec.ImuSpec`, the ``imu:`` keys) is
core/imu_spec.py, which scene.py reads; this module is what uses it while a simulation runs,
and nothing here is imported by the scene or the Simulator. :class:`ImuBank` samples the IMUs
that are due after a tick (node, ros/imu.py) or an output step (CLI): the ideal readings
(specific force and angular velocity in the site's axes) from :meth:`Simulator.site_readings`
(kernels/sensors.py), plus what a real IMU adds (:class:`ImuNoise`), with the discrete-time
model of Kalibr and Gazebo, per axis and per sample of interval Δt (s):

    b_k   = b_{k-1} + σ_b · √Δt · N(0, 1)           (bias random walk; b_0 = ``bias``)
    y_k   = ideal_k + b_k + σ_n / √Δt · N(0, 1)     (white noise of density σ_n)

σ_n is ``noise_density`` (accelerometer m/s²/√Hz, gyroscope rad/s/√Hz), σ_b is
``bias_random_walk`` (m/s³/√Hz, rad/s²/√Hz), ``bias`` the turn-on bias (m/s², rad/s). The
variance of one sample's white noise, σ_n²/Δt, is the covariance a sensor_msgs/Imu carries.
Random numbers come from numpy's PCG64 seeded by (``seed``, the site's name), so a run repeats
exactly and two IMUs with the same seed still have independent noise.

Contact (core/contact): a body held by the ground reads the holding force at once (it is a
wrench of the step, so at rest an IMU reads +g up). An impact changes the velocity in no time,
which no instantaneous reading sees; an IMU feels it as a real one integrating over its sample
does: the site's velocity jump Δv_S (the centre of mass's jump plus Δω × r, in the site's axes at
the impact) divided by the sample's interval Δt is added to the sample that contains the impact,
so the readings integrate to the right velocity change.
"""

from __future__ import annotations

import math
import zlib
from dataclasses import dataclass
from typing import TYPE_CHECKING, Mapping

import numpy as np

from .imu_spec import ImuChannel, ImuSpec
from .quaternion import quat_conjugate, quat_multiply, quat_rotate

if TYPE_CHECKING:
    from .simulator import Simulator

__all__ = ["ImuNoise", "ImuSample", "ImuBank", "NOT_PROVIDED", "noise_covariance"]


class ImuNoise:
    """The noise state of one IMU (its biases and random stream); :meth:`sample` adds it to ideal readings.

    Parameters
    ----------
    spec : ImuSpec
    site : str
        ``"<body>/<site>"``: with ``spec.seed``, the seed of the random stream.
    """

    def __init__(self, spec: ImuSpec, site: str):
        self.spec = spec
        self.site = site
        self._rng = np.random.default_rng([spec.seed, zlib.crc32(site.encode())])
        self.bias_accelerometer = np.array(spec.accelerometer.bias if spec.accelerometer else (0.0,) * 3, dtype=float)
        self.bias_gyroscope = np.array(spec.gyroscope.bias if spec.gyroscope else (0.0,) * 3, dtype=float)

    def sample(self, specific_force: np.ndarray, angular_velocity: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
        """One sample, Δt = ``dt`` s after the last: (specific force m/s², angular velocity rad/s), sensor axes.

        The biases walk first (b_k from b_{k-1}), then white noise of variance σ_n²/Δt is added.
        """
        force = self._channel(self.spec.accelerometer, self.bias_accelerometer, specific_force, dt)
        rate = self._channel(self.spec.gyroscope, self.bias_gyroscope, angular_velocity, dt)
        return force, rate

    def _channel(self, channel: ImuChannel | None, bias: np.ndarray, ideal: np.ndarray, dt: float) -> np.ndarray:
        ideal = np.asarray(ideal, dtype=float)
        if channel is None:
            return ideal.copy()
        if channel.bias_random_walk > 0.0:
            bias += channel.bias_random_walk * math.sqrt(dt) * self._rng.standard_normal(3)
        out = ideal + bias
        if channel.noise_density > 0.0:
            out = out + channel.noise_density / math.sqrt(dt) * self._rng.standard_normal(3)
        return out

    @staticmethod
    def variance(channel: ImuChannel | None, dt: float) -> float:
        """Variance (per axis) of one sample's white noise at interval ``dt``: σ_n²/Δt (0 for an ideal triad)."""
        if channel is None:
            return 0.0
        return channel.noise_density ** 2 / dt


#: Covariance (row-major 3×3) of a quantity the message does not carry: element 0 is −1 (sensor_msgs/Imu).
NOT_PROVIDED = (-1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)


@dataclass(frozen=True)
class ImuSample:
    """One IMU sample, as a sensor_msgs/Imu carries it.

    Attributes
    ----------
    site : str
        ``"<body>/<site>"`` (the message's frame_id).
    time : float
        Sim time, s.
    orientation_xyzw : ndarray (4,) or None
        Orientation of the sensor frame in the world (x, y, z, w); None if the IMU gives none.
    angular_velocity : ndarray (3,)
        rad/s, sensor axes (with noise and bias).
    specific_force : ndarray (3,)
        Acceleration minus gravity, m/s², sensor axes (REP-145; with noise and bias).
    covariances : tuple of three 9-tuples
        Row-major 3×3 covariances of orientation, angular velocity and linear acceleration:
        the white noise's variance σ_n²/Δt on the diagonal (zeros for an ideal triad, whose
        reading is exact); the orientation's is zeros (exact), or element 0 = −1 when
        the IMU gives no orientation (``orientation: false``).
    """

    site: str
    time: float
    orientation_xyzw: np.ndarray | None
    angular_velocity: np.ndarray
    specific_force: np.ndarray
    covariances: tuple[tuple[float, ...], tuple[float, ...], tuple[float, ...]]


def noise_covariance(variance: float) -> tuple[float, ...]:
    """The row-major 3×3 covariance of three independent axes of equal ``variance``."""
    return (variance, 0.0, 0.0, 0.0, variance, 0.0, 0.0, 0.0, variance)


class ImuBank:
    """The IMUs of a scene, sampled after the steps of a tick (node) or an output step (CLI).

    Parameters
    ----------
    imus : mapping of site name to ImuSpec
        ``Scene.imus``.
    previous : ImuBank, optional
        IMUs of the same site and spec keep their noise state and schedule from it (a body
        spawned or deleted at run time does not restart the other IMUs' noise).
    """

    def __init__(self, imus: Mapping[str, ImuSpec], previous: ImuBank | None = None):
        self.noise: dict[str, ImuNoise] = {}  # by site
        #: Sim time (s) of the next sample of each IMU with a rate (None: at the next call).
        self.next_due_s: dict[str, float | None] = {}
        for site, spec in imus.items():
            old = previous.noise.get(site) if previous is not None else None
            if old is not None and old.spec == spec:
                self.noise[site] = old
                self.next_due_s[site] = previous.next_due_s[site]
            else:
                self.noise[site] = ImuNoise(spec, site)
                self.next_due_s[site] = None
        self.sites = tuple(self.noise)
        #: Per site, Σ velocity jumps of impacts (m/s, the site's axes) not yet in a sample.
        self.pending_jumps: dict[str, np.ndarray] = {site: np.zeros(3) for site in self.sites}
        self._sites_of: dict[str, list[str]] = {}  # body → its IMU sites
        for site in self.sites:
            self._sites_of.setdefault(site.split("/", 1)[0], []).append(site)
        self._solver = None  # the ContactSolver whose events were read up to ...
        self._seen = 0  # ... this index
        self._last_event = None  # the last of them (a reset clears the list: then it is gone)

    def _gather_impacts(self, sim: Simulator, step_dt: float) -> None:
        """Add the impacts recorded since the last call to :attr:`pending_jumps` (of the sites of their body).

        On a new solver or after a reset (its event list cleared) only the events of the last
        ``step_dt`` are taken, so a bank made for a running simulation replays nothing older.
        """
        solver = getattr(sim, "contact", None)
        if solver is None:
            return
        events = solver.events
        fresh = solver is not self._solver or (self._seen and (len(events) < self._seen
                                                               or events[self._seen - 1] is not self._last_event))
        if fresh:
            self._solver, self._seen = solver, 0
            for jump in self.pending_jumps.values():
                jump[:] = 0.0
        since = sim.time - step_dt if fresh else -math.inf
        model = sim.model
        index = None
        for event in events[self._seen:]:
            if (event.kind != "impact" or not event.delta_v_world or event.time <= since
                    or event.body not in self._sites_of):
                continue
            if index is None:
                index = {name: s for s, name in enumerate(model.site_names)}
            for site in self._sites_of[event.body]:
                s = index[site]
                b = int(model.site_body[s])
                q_WP = np.asarray(event.q_WP, dtype=float)
                jump_W = np.asarray(event.delta_v_world) + quat_rotate(
                    q_WP, np.cross(np.asarray(event.delta_w_principal), model.site_p_P[s]))
                if not model.site_world_axes[s]:  # the body's axes B at the impact: q_WB = q_WP ⊗ q_BPᶜ
                    q_WB = quat_multiply(q_WP, quat_conjugate(model.q_BP[b]))
                    jump_W = quat_rotate(quat_conjugate(q_WB), jump_W)
                self.pending_jumps[site] += jump_W
        self._seen = len(events)
        self._last_event = events[-1] if events else None

    def sample(self, sim: Simulator, step_dt: float) -> list[ImuSample]:
        """The samples due at ``sim.time``, read right after the step(s) just taken.

        An IMU without ``rate`` samples at every call, Δt = ``step_dt`` (s of sim time, the
        interval between calls); one with ``rate`` at the first call at or after each multiple
        of 1/rate from its first sample (at most one per call: a rate above the call rate gives
        one sample per call, each with Δt = 1/rate), Δt = 1/rate.
        """
        if not self.sites:
            return []
        self._gather_impacts(sim, step_dt)
        t = sim.time
        due = []
        for site in self.sites:
            next_due = self.next_due_s[site]
            if next_due is None or t >= next_due - 1e-9 * max(1.0, abs(t)):
                due.append(site)
        if not due:
            return []
        readings = sim.site_readings(due)
        out = []
        for k, site in enumerate(due):
            noise = self.noise[site]
            spec = noise.spec
            if spec.rate is None:
                dt = step_dt
            else:
                dt = 1.0 / spec.rate
                next_due = self.next_due_s[site]
                next_due = t + dt if next_due is None else next_due + dt
                if next_due <= t:  # fallen behind by more than one sample: go on from now
                    next_due = t + dt
                self.next_due_s[site] = next_due
            jump = self.pending_jumps[site]
            force, rate = noise.sample(readings.specific_force[k] + jump / dt, readings.angular_velocity[k], dt)
            jump[:] = 0.0
            covariances = ((0.0,) * 9 if spec.orientation else NOT_PROVIDED,
                           noise_covariance(ImuNoise.variance(spec.gyroscope, dt)),
                           noise_covariance(ImuNoise.variance(spec.accelerometer, dt)))
            out.append(ImuSample(site, t, readings.orientation_xyzw[k].copy() if spec.orientation else None,
                                 rate, force, covariances))
        return out
