"""IMU sensor models on sites: what a scene declares under ``imu:``, and the noise added to ideal readings.

Data and the noise model only: the scene schema (:class:`ImuSpec`, :data:`IMU_KEYS`, parsed by
scene.py) and :class:`ImuNoise`; the sampler that reads a running Simulator is
:class:`~rigid_body_sim.core.imu_bank.ImuBank`. The ideal readings (specific force and angular
velocity in the site's axes) come from :meth:`Simulator.site_readings` (kernels/sensors.py). This
module adds what a real IMU adds, with the
discrete-time model of Kalibr and Gazebo, per axis and per sample of interval Δt (s):

    b_k   = b_{k-1} + σ_b · √Δt · N(0, 1)           (bias random walk; b_0 = ``bias``)
    y_k   = ideal_k + b_k + σ_n / √Δt · N(0, 1)     (white noise of density σ_n)

σ_n is ``noise_density`` (accelerometer m/s²/√Hz, gyroscope rad/s/√Hz), σ_b is
``bias_random_walk`` (m/s³/√Hz, rad/s²/√Hz), ``bias`` the turn-on bias (m/s², rad/s). The
variance of one sample's white noise, σ_n²/Δt, is the covariance a sensor_msgs/Imu carries.
Random numbers come from numpy's PCG64 seeded by (``seed``, the site's name), so a run repeats
exactly and two IMUs with the same seed still have independent noise.

Scene form (under a site; every key optional, an empty mapping is an ideal IMU)::

    imu:
      rate: 200.0          # Hz of sim time; absent = one sample per output step (node tick)
      seed: 7              # integer ≥ 0, default 0
      orientation: true    # false: the message says it has no orientation (covariance[0] = -1)
      accelerometer: {noise_density: 2.0e-3, bias: [0.02, 0, 0], bias_random_walk: 3.0e-3}
      gyroscope: {noise_density: 1.7e-4, bias: 0.001, bias_random_walk: 2.0e-5}
"""

from __future__ import annotations

import math
import zlib
from dataclasses import dataclass

import numpy as np

__all__ = ["ImuChannel", "ImuSpec", "ImuNoise", "ImuSample", "IMU_KEYS", "IMU_CHANNEL_KEYS", "NOT_PROVIDED",
           "noise_covariance"]

#: Keys of an ``imu:`` mapping and of its ``accelerometer`` / ``gyroscope`` mappings.
IMU_KEYS = ("rate", "seed", "orientation", "accelerometer", "gyroscope")
IMU_CHANNEL_KEYS = ("noise_density", "bias", "bias_random_walk")


@dataclass(frozen=True)
class ImuChannel:
    """Noise of one triad (accelerometer or gyroscope), per axis, in the sensor's axes.

    Attributes
    ----------
    noise_density : float
        σ_n: white-noise density (m/s²/√Hz or rad/s/√Hz), ≥ 0.
    bias : tuple of 3 float
        Turn-on bias b_0 (m/s² or rad/s).
    bias_random_walk : float
        σ_b: bias random-walk density (m/s³/√Hz or rad/s²/√Hz), ≥ 0.
    """

    noise_density: float = 0.0
    bias: tuple[float, float, float] = (0.0, 0.0, 0.0)
    bias_random_walk: float = 0.0

    @property
    def ideal(self) -> bool:
        return self.noise_density == 0.0 and self.bias_random_walk == 0.0 and not any(self.bias)


@dataclass(frozen=True)
class ImuSpec:
    """An IMU declared on a site.

    Attributes
    ----------
    rate : float or None
        Samples per second of sim time; None: one per output step.
    seed : int
        Seed of its noise (with the site's name).
    orientation : bool
        Whether its messages carry the orientation of the sensor frame.
    accelerometer, gyroscope : ImuChannel or None
        The noise of each triad; None when the scene declares none (an ideal triad).
    """

    rate: float | None = None
    seed: int = 0
    orientation: bool = True
    accelerometer: ImuChannel | None = None
    gyroscope: ImuChannel | None = None


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
