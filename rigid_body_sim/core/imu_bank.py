"""The IMUs of a running simulation: which are due after a step, their ideal readings plus noise, as samples.

The runtime half of the IMU model: imu.py holds what a scene declares (:class:`ImuSpec`) and
the noise model (:class:`ImuNoise`); this module samples them from a :class:`Simulator` whose
:meth:`~rigid_body_sim.core.simulator.Simulator.site_readings` (kernels/sensors.py) gives the ideal
readings. The node (ros/imu.py) and the CLI call :meth:`ImuBank.sample` after each tick or
output step.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Mapping

from .imu import NOT_PROVIDED, ImuNoise, ImuSample, ImuSpec, noise_covariance

if TYPE_CHECKING:
    from .simulator import Simulator

__all__ = ["ImuBank"]


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

    def sample(self, sim: Simulator, step_dt: float) -> list[ImuSample]:
        """The samples due at ``sim.time``, read right after the step(s) just taken.

        An IMU without ``rate`` samples at every call, Δt = ``step_dt`` (s of sim time, the
        interval between calls); one with ``rate`` at the first call at or after each multiple
        of 1/rate from its first sample (at most one per call: a rate above the call rate gives
        one sample per call, each with Δt = 1/rate), Δt = 1/rate.
        """
        if not self.sites:
            return []
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
            force, rate = noise.sample(readings.specific_force[k], readings.angular_velocity[k], dt)
            covariances = ((0.0,) * 9 if spec.orientation else NOT_PROVIDED,
                           noise_covariance(ImuNoise.variance(spec.gyroscope, dt)),
                           noise_covariance(ImuNoise.variance(spec.accelerometer, dt)))
            out.append(ImuSample(site, t, readings.orientation_xyzw[k].copy() if spec.orientation else None,
                                 rate, force, covariances))
        return out
