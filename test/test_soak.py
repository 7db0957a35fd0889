"""Soak: 10⁶ physics steps through the node with wrenches and parameters changing (slow;
``test_soak_short`` runs 3,000 of them, with a parameter change every 5 ticks, in the default suite).

The node runs in-process under the harness, paused, and advances through ``~/step`` with 50 to
200 substeps per tick, so 10⁶ steps take about 8,000 ticks. Every tick the harness publishes a
random wrench on ``pushed`` in one of its frames (now and then an impulse, an all-zero wrench
that clears a hold, or a message the node must drop); every 50 ticks it changes integrator
(rk4 / splitting), substeps, rate_hz, real_time_factor and wrench_timeout at random, atomically,
through the parameter service. Nothing ever touches ``free``, an asymmetric body tumbling
torque-free, so its kinetic energy and |L| are invariants of the exact motion.

Checks:

- RSS of the process (``/proc/self/status``) flat after the warm-up (≤ ``RSS_FLAT_KIB`` growth);
- ``tracemalloc``: traced Python memory does not grow over two traced stretches (early and at the
  end) of ``TRACED_STEPS`` steps each, from a quarter into the stretch (past the first-use
  allocations that follow ``tracemalloc.start()``) to its end (tracing makes a step ~4× slower, so
  it is not on throughout);
- held wrenches never more than the frames of ``pushed``, and none once the last timeout passed;
- the free body within its integrators' envelope: |L| to round-off (splitting keeps |L| exactly;
  rk4's truncation error per step is ~(|ω|·dt)⁵ ≤ 4e-16 here), energy to the splitting's bounded
  O((|ω|·dt)²) error (no secular drift for either method at these steps).
"""

from __future__ import annotations

import gc
import math
import os
import random
import time
import tracemalloc
from pathlib import Path

import numpy as np
import pytest
import yaml
from rclpy.experimental import EventsExecutor

from rigid_body_sim.ros.diagnostics import level_name
from rigid_body_sim.testing import SimHarness

pytestmark = pytest.mark.ros

#: Steps of the slow soak (the environment variable shortens it while working on the test).
SOAK_STEPS = int(os.environ.get("RIGID_BODY_SIM_SOAK_STEPS", 1_000_000))
RSS_FLAT_KIB = 4096
TRACED_FLAT_BYTES = 64 * 1024
SCENE = {
    "bodies": {
        "pushed": {"mass": 2.0, "inertia": {"box": [1.0, 0.6, 0.4]},
                   "sites": {"corner": {"position": [0.5, 0.3, 0.0]}, "nozzle": {"position": [-0.5, 0.0, 0.2], "axes": "world"}}},
        "free": {"mass": 1.0, "inertia": {"principal": [1.0, 2.0, 2.5]}, "twist": {"angular": [0.3, 1.0, 0.2]}},
    }
}
PUSHED_FRAMES = ("world", "pushed", "pushed/world_aligned", "pushed/corner", "pushed/nozzle")
CHOICES = {
    "integrator": ("rk4", "splitting"),
    "substeps": (50, 100, 200),
    "rate_hz": (50.0, 100.0, 200.0),
    "real_time_factor": (0.5, 1.0, 2.0),
    "wrench_timeout": (0.0, 0.02, 0.2),
}
MAX_DT = max(CHOICES["real_time_factor"]) / (min(CHOICES["rate_hz"]) * min(CHOICES["substeps"]))  # s


def rss_kib() -> int:
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1])
    raise RuntimeError("no VmRSS")


def free_invariants(harness: SimHarness) -> tuple[float, float]:
    sim = harness.node.simulator
    index = sim.body_names.index("free")
    return float(sim.kinetic_energy()[index]), float(np.linalg.norm(sim.angular_momentum()[index]))


@pytest.mark.slow
@pytest.mark.timeout(3600)
def test_soak_million_steps(tmp_path):
    run_soak(tmp_path, SOAK_STEPS, check_memory=True)


def test_soak_short(tmp_path):
    """The same run, 3,000 steps, for the default suite: holds bounded, the envelope kept, no stop."""
    run_soak(tmp_path, 3_000, check_memory=False)


def run_soak(tmp_path, TOTAL_STEPS: int, check_memory: bool) -> None:
    TRACED_STEPS = TOTAL_STEPS // 40
    WARM_UP_STEPS = TOTAL_STEPS // 20
    every = 50 if TOTAL_STEPS >= 100_000 else 5  # ticks between parameter changes
    scene_path = tmp_path / "soak.yaml"
    scene_path.write_text(yaml.safe_dump(SCENE))
    rng = random.Random(2024)
    start_params = {"integrator": "rk4", "substeps": 100, "wrench_timeout": 0.2, "diagnostics_period": 0.0}
    wall_start, cpu_start = time.monotonic(), time.process_time()
    with SimHarness(scene_path, parameters=start_params, executor=EventsExecutor) as node:
        energy_0, momentum_0 = free_invariants(node)
        substeps = 100
        steps = ticks = changes = 0
        max_held = 0
        rss: list[tuple[int, int]] = []
        traced: list[list[tuple[int, int]]] = []  # per stretch: (steps, traced bytes) samples
        tracing = False
        windows = [(WARM_UP_STEPS * 2, WARM_UP_STEPS * 2 + TRACED_STEPS), (TOTAL_STEPS - TRACED_STEPS, TOTAL_STEPS)]
        worst_energy = worst_momentum = 0.0
        statuses = set()
        while steps < TOTAL_STEPS:
            # Tracing on and off at tick boundaries, around the two traced stretches.
            inside = check_memory and any(a <= steps < b for a, b in windows)
            if inside and not tracing:
                tracemalloc.start()
                tracing = True
                traced.append([])
            elif tracing and not inside:
                gc.collect()
                traced[-1].append((steps, tracemalloc.get_traced_memory()[0]))
                tracemalloc.stop()
                tracing = False
            if tracing and ticks % 10 == 0:
                gc.collect()
                traced[-1].append((steps, tracemalloc.get_traced_memory()[0]))

            if ticks % every == every - 1:
                change = {name: rng.choice(values) for name, values in CHOICES.items() if rng.random() < 0.6}
                if change:
                    result = node.set_parameters_atomically(**change)
                    assert result.successful, result.reason
                    substeps = change.get("substeps", substeps)
                    changes += 1
            r = rng.random()
            frame = rng.choice(PUSHED_FRAMES)
            if r < 0.70:
                node.publish_wrench("pushed", force=[rng.gauss(0, 0.5) for _ in range(3)],
                                    torque=[rng.gauss(0, 0.05) for _ in range(3)], frame_id=frame)
            elif r < 0.80:
                node.publish_wrench("pushed", frame_id=frame)  # all-zero: clears that hold
            elif r < 0.90:
                node.publish_impulse("pushed", linear=[rng.gauss(0, 0.01) for _ in range(3)],
                                     angular=[rng.gauss(0, 0.001) for _ in range(3)], frame_id=frame)
            else:
                node.publish_wrench("pushed", force=(math.nan, 1.0, 0.0), frame_id=rng.choice((frame, "map")))
            max_held = max(max_held, len(node.node.held_wrenches))
            node.step()
            steps += substeps
            ticks += 1
            if ticks % (2 * every) == 0:
                energy, momentum = free_invariants(node)
                worst_energy = max(worst_energy, abs(energy - energy_0) / energy_0)
                worst_momentum = max(worst_momentum, abs(momentum - momentum_0) / momentum_0)
            if ticks % (10 * every) == 0:
                rss.append((steps, rss_kib()))
                statuses.add(level_name(node.node.diagnostics().status[0]))
        if tracing:
            gc.collect()
            traced[-1].append((steps, tracemalloc.get_traced_memory()[0]))
            tracemalloc.stop()
        rss.append((steps, rss_kib()))

        # After the longest timeout the holds are gone.
        node.set_parameters_atomically(wrench_timeout=0.05)
        node.step(max(1, math.ceil(0.05 / (node.node.simulator.dt * substeps))) + 1)
        held_after = len(node.node.held_wrenches)
        energy_1, momentum_1 = free_invariants(node)
        stopped = node.node.simulator.stopped_bodies
        rejected = dict(node.node.rejected)
        sim_time = node.node.simulator.time
    wall, cpu = time.monotonic() - wall_start, time.process_time() - cpu_start

    after_warm_up = [kib for s, kib in rss if s >= WARM_UP_STEPS] or [rss[-1][1]]
    growth = []  # per stretch: (bytes at a quarter in, bytes at the end)
    for samples in traced:
        quarter = samples[0][0] + (samples[-1][0] - samples[0][0]) // 4
        growth.append((next(b for s_, b in samples if s_ >= quarter), samples[-1][1]))
    rss_growth = after_warm_up[-1] - after_warm_up[0]
    w_max = math.sqrt(2.0 * energy_0 / 1.0)  # |ω| ≤ √(2E / I_min), I_min = 1 kg·m²
    energy_bound = 10.0 * (w_max * MAX_DT) ** 2 + 1e-9  # splitting: bounded O((|ω|dt)²); rk4 far below
    momentum_bound = 1e-9  # round-off: ~1e6 steps × a few ε, growing like √n in practice
    print(f"\n[soak] {steps} steps in {ticks} ticks ({sim_time:.1f} s of sim time), {changes} parameter changes; "
          f"{wall:.0f} s wall, {cpu:.0f} s CPU")
    print(f"[soak] RSS {after_warm_up[0]} KiB after warm-up → {after_warm_up[-1]} KiB at the end (Δ {rss_growth} KiB); "
          f"samples {[kib for _s, kib in rss]}")
    print(f"[soak] tracemalloc, two stretches of {TRACED_STEPS} steps: traced {[g for g in growth]} bytes "
          f"(a quarter in, at the end); first sample of each {[t[0][1] for t in traced]} bytes")
    print(f"[soak] held wrenches at most {max_held} (frames: {len(PUSHED_FRAMES)}), {held_after} after the timeout; "
          f"rejected {rejected}; diagnostics levels seen {sorted(statuses)}")
    print(f"[soak] free body: |ΔE|/E = {abs(energy_1 - energy_0) / energy_0:.2e} (worst {worst_energy:.2e}, bound "
          f"{energy_bound:.1e}), |Δ|L||/|L| = {abs(momentum_1 - momentum_0) / momentum_0:.2e} (worst {worst_momentum:.2e}, "
          f"bound {momentum_bound:.0e})")

    assert steps >= TOTAL_STEPS and stopped == ()
    if check_memory:
        assert rss_growth <= RSS_FLAT_KIB, rss
        assert len(traced) == 2 and all(b1 - b0 <= TRACED_FLAT_BYTES for b0, b1 in growth), traced
    assert max_held <= len(PUSHED_FRAMES) and held_after == 0
    assert max(worst_energy, abs(energy_1 - energy_0) / energy_0) <= energy_bound
    assert max(worst_momentum, abs(momentum_1 - momentum_0) / momentum_0) <= momentum_bound
    assert statuses <= {"OK"}
