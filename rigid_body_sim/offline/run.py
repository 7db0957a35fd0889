"""Offline runs: step a scene as fast as possible, sample it, and summarise what was conserved.

:func:`run_offline` is the loop behind ``rigid-body-sim run``; it needs no ROS. It steps a
:class:`~rigid_body_sim.core.Simulator` (whose scene may script wrenches) for a duration,
hands the state to ``on_sample`` callbacks every ``sample_every`` steps (and at the start and
the end), reports progress, and returns a :class:`RunSummary` with the drift of each body's
energy and |L| over the samples (and, with ground contact, its impacts and lowest gap).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Callable, Iterable

import numpy as np

from ..core import Simulator
from ..core.contact.query import lowest_gaps, resting_bodies

__all__ = ["RunSummary", "run_offline", "steps_for", "sample_interval", "MAX_RUN_STEPS"]

#: A duration within this fraction of a step of a whole number of steps counts as that number.
STEP_ROUNDING = 1e-9
#: Most steps a run may take, and most steps between two samples: 2^53, so that step counts
#: are exact in float64 (and a run of 2^53 steps of 1 µs already lasts 285 years).
MAX_RUN_STEPS = 2**53


def steps_for(duration: float, dt: float) -> int:
    """Steps of ``dt`` needed to cover ``duration`` (s): ``ceil(duration / dt)``, where a duration
    within 1e-9 steps of a whole number counts as that number.

    Raises
    ------
    ValueError
        If ``duration`` or ``dt`` is not a finite number > 0, or the run would take more than
        :data:`MAX_RUN_STEPS` steps (``--dt 1e-320`` makes it infinite).
    """
    if not (math.isfinite(duration) and duration > 0.0):
        raise ValueError(f"duration: expected a finite number of seconds > 0, got {duration!r}")
    if not (math.isfinite(dt) and dt > 0.0):
        raise ValueError(f"dt: expected a finite number of seconds > 0, got {dt!r}")
    ratio = duration / dt
    if not ratio <= MAX_RUN_STEPS:
        raise ValueError(f"dt: expected a step giving at most 2^53 steps over the duration, got {duration:g} s / "
                         f"{dt:g} s = {ratio:.3g} steps")
    nearest = round(ratio)
    return max(1, int(nearest if abs(ratio - nearest) <= STEP_ROUNDING * max(1.0, ratio) else math.ceil(ratio)))


def sample_interval(rate_hz: float, dt: float) -> int:
    """Steps between samples for ``rate_hz`` samples per sim second: ``round(1 / (rate_hz·dt))``, ≥ 1.

    Raises
    ------
    ValueError
        If ``rate_hz`` is not a finite number > 0, or there would be more than
        :data:`MAX_RUN_STEPS` steps between samples (``rate_hz·dt`` underflows to 0).
    """
    if not (math.isfinite(rate_hz) and rate_hz > 0.0):
        raise ValueError(f"rate: expected a finite number of samples per second > 0, got {rate_hz!r}")
    interval = 1.0 / (rate_hz * dt) if rate_hz * dt > 0.0 else math.inf
    if not interval <= MAX_RUN_STEPS:
        raise ValueError(f"rate: expected a rate giving at least one sample per 2^53 steps, got {rate_hz:g} samples/s "
                         f"at a step of {dt:g} s")
    return max(1, int(round(interval)))


@dataclass(frozen=True)
class RunSummary:
    """What a run did.

    Attributes
    ----------
    steps : int
        Physics steps taken.
    sim_time : float
        Sim time reached, s.
    wall_time : float
        Wall-clock time of the stepping and sampling, s.
    samples : int
        Times ``on_sample`` was called.
    energy_initial, energy_drift : dict of str to float
        Per body: energy at t = 0 (J), and max over the samples of |E(t) − E(0)| / |E(0)|
        (absolute, J, when E(0) = 0). Energy is kinetic plus gravitational potential.
    momentum_initial, momentum_drift : dict of str to float
        The same for |L| about the centre of mass (kg·m²/s).
    stopped : bool
        True if ``stop`` ended the run before the duration (e.g. on SIGTERM).
    contact : dict or None
        With ground contact (``Simulator.contact``): ``impacts`` and ``events`` recorded in the run,
        ``resting`` bodies in persistent contact at the end, ``lowest_gap`` the lowest gap (m) of
        any collision shape over the samples (negative: inside the ground), ``impact_energy`` the
        kinetic energy change summed over the impacts (J, ≤ 0); None without contact.
    """

    steps: int
    sim_time: float
    wall_time: float
    samples: int
    energy_initial: dict[str, float]
    energy_drift: dict[str, float]
    momentum_initial: dict[str, float]
    momentum_drift: dict[str, float]
    stopped: bool = False
    contact: dict | None = None

    @property
    def real_time_factor(self) -> float:
        """Sim seconds per wall-clock second."""
        return self.sim_time / self.wall_time if self.wall_time > 0.0 else math.inf


def run_offline(sim: Simulator, duration: float, *, sample_every: int = 1,
                on_sample: Iterable[Callable[[Simulator], None]] = (),
                progress: Callable[[int], None] | None = None,
                stop: Callable[[], bool] | None = None) -> RunSummary:
    """Step ``sim`` from its current state for ``duration`` seconds of sim time.

    Parameters
    ----------
    sim : Simulator
    duration : float
        s of sim time; :func:`steps_for` steps are taken.
    sample_every : int
        Steps between samples (≥ 1). Samples are taken at the start, every ``sample_every``
        steps, and at the end.
    on_sample : iterable of callables
        Called with ``sim`` at each sample (a CSV writer, a recorder...).
    progress : callable, optional
        Called with the number of steps just taken, after each batch of steps.
    stop : callable, optional
        Asked after each sample; when it returns True the run ends there (``stopped`` is set),
        so a signal ends a run between two samples, never inside a write.

    Raises
    ------
    NonFiniteStateError
        From :meth:`Simulator.step`; the samples up to then have been handed out.
    """
    if isinstance(sample_every, bool) or not isinstance(sample_every, int) or sample_every < 1:
        raise ValueError(f"sample_every: expected a whole number ≥ 1, got {sample_every!r}")
    total = steps_for(duration, sim.dt)
    callbacks = list(on_sample)
    names = sim.body_names
    energy0 = sim.kinetic_energy() + sim.potential_energy()
    momentum0 = np.linalg.norm(sim.angular_momentum(), axis=1)
    energy_drift = np.zeros(len(names))
    momentum_drift = np.zeros(len(names))
    samples = 0
    solver = sim.contact
    events_before = len(solver.events) if solver is not None else 0
    lowest_gap = math.inf

    def sample() -> None:
        nonlocal samples, energy_drift, momentum_drift, lowest_gap
        if solver is not None:
            lowest_gap = min(lowest_gap, float(lowest_gaps(sim).min(initial=math.inf)))
        energy = sim.kinetic_energy() + sim.potential_energy()
        momentum = np.linalg.norm(sim.angular_momentum(), axis=1)
        energy_drift = np.maximum(energy_drift, _relative(energy, energy0))
        momentum_drift = np.maximum(momentum_drift, _relative(momentum, momentum0))
        for callback in callbacks:
            callback(sim)
        samples += 1

    start_wall = time.perf_counter()
    start_steps = sim.step_count
    sample()
    done = 0
    stopped = False
    while done < total:
        if stop is not None and stop():
            stopped = True
            break
        n = min(sample_every, total - done)
        sim.step(n)
        done += n
        sample()
        if progress is not None:
            progress(n)
    wall = time.perf_counter() - start_wall
    contact = None
    if solver is not None:
        events = solver.events[events_before:] if len(solver.events) >= events_before else solver.events
        impacts = [e for e in events if e.kind == "impact"]
        contact = {"impacts": len(impacts), "events": len(events), "resting": len(resting_bodies(sim)),
                   "lowest_gap": lowest_gap, "impact_energy": sum(e.energy_after - e.energy_before for e in impacts)}
    return RunSummary(
        steps=sim.step_count - start_steps, sim_time=sim.time, wall_time=wall, samples=samples,
        energy_initial=dict(zip(names, energy0.tolist())), energy_drift=dict(zip(names, energy_drift.tolist())),
        momentum_initial=dict(zip(names, momentum0.tolist())),
        momentum_drift=dict(zip(names, momentum_drift.tolist())), stopped=stopped, contact=contact,
    )


def _relative(value: np.ndarray, initial: np.ndarray) -> np.ndarray:
    """|value − initial| / |initial|, or the absolute change where initial is 0."""
    change = np.abs(value - initial)
    scale = np.abs(initial)
    return np.where(scale > 0.0, change / np.where(scale > 0.0, scale, 1.0), change)
