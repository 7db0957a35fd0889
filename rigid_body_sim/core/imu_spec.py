"""What a scene declares under a site's ``imu:``: the IMU's rate, seed, orientation flag and noise parameters.

Data only, parsed and validated by scene.py (the scene schema). The model that samples it from
a running simulation, noise included, is core/imu.py. Scene form (under a site; every key
optional, an empty mapping is an ideal IMU)::

    imu:
      rate: 200.0          # Hz of sim time; absent = one sample per output step (node tick)
      seed: 7              # integer ≥ 0, default 0
      orientation: true    # false: the message says it has no orientation (covariance[0] = -1)
      accelerometer: {noise_density: 2.0e-3, bias: [0.02, 0, 0], bias_random_walk: 3.0e-3}
      gyroscope: {noise_density: 1.7e-4, bias: 0.001, bias_random_walk: 2.0e-5}

Units: ``noise_density`` σ_n in m/s²/√Hz (accelerometer) or rad/s/√Hz (gyroscope),
``bias_random_walk`` σ_b in m/s³/√Hz or rad/s²/√Hz, ``bias`` in m/s² or rad/s.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["ImuChannel", "ImuSpec", "IMU_KEYS", "IMU_CHANNEL_KEYS"]

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
