"""One way to time things in every benchmark: calibrated calls, interleaved repeats, median and range.

A :class:`Case` is something to time: ``run(k)`` does k units of work (k steps, k calls),
``setup()`` (untimed) puts it back at its start state before every sample, so every sample
starts from the same state and none runs into a blow-up. :func:`interleaved` first calibrates
each case's k so that one sample lasts about ``min_seconds``, then takes ``repeats`` samples of
every case in turn (round-robin: a load change on the shared machine hits all cases alike),
with the garbage collector off during each timed sample (as :mod:`timeit` does). The result
per case is a :class:`Stats` of seconds per unit: median, min and max over the repeats.

Quick and full modes differ in the sizes they sweep and in ``min_seconds``, never in
``repeats`` (≥ :data:`MIN_REPEATS`).
"""

from __future__ import annotations

import gc
import math
import statistics
import time
from dataclasses import dataclass, field
from typing import Callable, Hashable

#: Every figure is the median of at least this many samples.
MIN_REPEATS = 5


@dataclass(frozen=True)
class Stats:
    """Seconds per unit over ``repeats`` samples: median, min, max; ``units`` per sample."""

    median: float
    low: float
    high: float
    repeats: int
    units: int

    @classmethod
    def of(cls, per_unit: list[float], units: int) -> "Stats":
        return cls(statistics.median(per_unit), min(per_unit), max(per_unit), len(per_unit), units)

    def scaled(self, factor: float) -> "Stats":
        """The same samples times ``factor`` (e.g. 1e6 for µs; per body: 1/N)."""
        return Stats(self.median * factor, self.low * factor, self.high * factor, self.repeats, self.units)

    def rate(self, per_unit: float = 1.0) -> "Stats":
        """Units per second (× per_unit, e.g. bodies per step): median, and min/max swapped accordingly."""
        return Stats(per_unit / self.median, per_unit / self.high, per_unit / self.low, self.repeats, self.units)

    def text(self, digits: int = 3) -> str:
        """``median (min–max)``."""
        return f"{self.median:.{digits}g} ({self.low:.{digits}g}–{self.high:.{digits}g})"

    def as_row(self, prefix: str) -> dict[str, float]:
        return {f"{prefix}": self.median, f"{prefix}_min": self.low, f"{prefix}_max": self.high,
                f"{prefix}_repeats": self.repeats}


@dataclass
class Case:
    """Something to time: ``run(k)`` does k units; ``setup()`` resets it (untimed) before each sample.

    ``max_units`` caps k (e.g. steps a state can take before drifting somewhere unrepresentative).
    ``timed(k)``, if given, replaces setup + run: it does both and returns the seconds of the run
    itself (a case timed in another process: benchmarks/core_compare.py).
    """

    key: Hashable
    run: Callable[[int], object] = lambda k: None
    setup: Callable[[], object] = lambda: None
    max_units: int = 10**9
    timed: Callable[[int], float] | None = None
    units: int = field(default=0, init=False)


def _timed(case: Case, k: int) -> float:
    if case.timed is not None:
        return case.timed(k)
    case.setup()
    gc_was_enabled = gc.isenabled()
    gc.disable()
    try:
        t0 = time.perf_counter()
        case.run(k)
        return time.perf_counter() - t0
    finally:
        if gc_was_enabled:
            gc.enable()


def calibrate(case: Case, min_seconds: float) -> int:
    """The number of units per sample for about ``min_seconds`` per sample (after one warm-up)."""
    k = 1
    _timed(case, 1)  # warm-up: first-call allocations, caches
    while True:
        elapsed = _timed(case, k)
        if elapsed >= min_seconds or k >= case.max_units:
            return min(k, case.max_units)
        if elapsed >= 0.2 * min_seconds:  # close enough to extrapolate
            return max(1, min(case.max_units, math.ceil(k * min_seconds / max(elapsed, 1e-9))))
        k = min(case.max_units, k * 4)


def interleaved(cases: list[Case], repeats: int = MIN_REPEATS, min_seconds: float = 0.05,
                log: Callable[[str], object] | None = None) -> dict[Hashable, Stats]:
    """Time every case ``repeats`` times, round-robin; seconds per unit per case key."""
    if repeats < MIN_REPEATS:
        raise ValueError(f"repeats: expected ≥ {MIN_REPEATS} (medians of ≥ {MIN_REPEATS}), got {repeats}")
    for case in cases:
        case.units = calibrate(case, min_seconds)
    samples: dict[Hashable, list[float]] = {case.key: [] for case in cases}
    for _ in range(repeats):
        for case in cases:
            samples[case.key].append(_timed(case, case.units) / case.units)
    out = {case.key: Stats.of(samples[case.key], case.units) for case in cases}
    if log:
        for case in cases:
            log(f"    {case.key}: {out[case.key].scaled(1e6).text()} µs per unit, {case.units} units per sample")
    return out
