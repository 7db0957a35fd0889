"""Shared helpers of the core's physics tests: scenes built in code, random bodies, log-log fits.

Everything random here takes a seeded ``numpy.random.Generator`` from the caller, so every
test is reproducible. Quaternions are (w, x, y, z) unless a name says ``_xyzw``.

At the end, helpers of the stop tests: node processes started, signalled and checked.
"""

from __future__ import annotations

import os
import signal
import subprocess
import time
from pathlib import Path
from typing import Any

import numpy as np
from hypothesis import HealthCheck, settings
from hypothesis import strategies as st
import yaml

from rigid_body_sim.core import INTEGRATORS, Scene, Simulator, load_scene
from rigid_body_sim.core.quaternion import quat_wxyz_from_xyzw, quat_xyzw_from_wxyz

#: The fixed-step integrators, in the order of the table: every method of
#: :data:`~rigid_body_sim.core.integrators.INTEGRATORS` with an order (``reference`` is adaptive
#: and is tested on its own).
FIXED_STEP_INTEGRATORS = tuple(name for name, method in INTEGRATORS.items() if method.order is not None)

#: Observed convergence order each fixed-step method must show: the order the table claims.
ORDER = {name: INTEGRATORS[name].order for name in FIXED_STEP_INTEGRATORS}

#: The compiled fixed-step methods (a ``code`` stepping dispatches on) and the ones the Simulator
#: steps in numpy (no ``code``: a step costs a few hundred µs of Python, so long runs of them are
#: kept short in the default suite).
COMPILED_INTEGRATORS = tuple(name for name in FIXED_STEP_INTEGRATORS if INTEGRATORS[name].code is not None)
NUMPY_STEPPED_INTEGRATORS = tuple(name for name in FIXED_STEP_INTEGRATORS if INTEGRATORS[name].code is None)

#: The Lie–Poisson splittings: every stage an exact rotation, so |L| is kept to round-off.
SPLITTING_FAMILY = ("splitting", "symmetric_splitting", "exact_rotor_splitting")

#: Methods whose free rotor is the exact flow: torque-free, their only error is round-off
#: (their order shows with applied torques; test_stability.py).
EXACT_FREE_ROTOR = ("exact_rotor_splitting",)

#: Unit round-off of float64.
EPS = np.finfo(float).eps


def scene_of(bodies: dict[str, dict[str, Any]], gravity: Any = None) -> Scene:
    """A scene from a dict of body specs (the YAML schema, already parsed)."""
    data: dict[str, Any] = {"bodies": bodies}
    if gravity is not None:
        data["gravity"] = list(gravity)
    return load_scene(data)


def random_unit_quaternion(rng: np.random.Generator, size: int | None = None) -> np.ndarray:
    """Uniformly distributed unit quaternions (w, x, y, z), shape (4,) or (size, 4)."""
    q = rng.normal(size=(4,) if size is None else (size, 4))
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def random_principal_moments(rng: np.random.Generator, low: float = 0.5, high: float = 2.0) -> np.ndarray:
    """Three distinct principal moments (kg·m²) in [low, high) that satisfy the triangle inequality."""
    while True:
        moments = rng.uniform(low, high, 3)
        spread = np.diff(np.sort(moments))
        if moments.max() < moments.sum() - moments.max() and spread.min() > 0.05 * high:
            return moments


def random_rotation_matrix(rng: np.random.Generator) -> np.ndarray:
    """A uniformly distributed proper rotation matrix, shape (3, 3)."""
    from scipy.spatial.transform import Rotation

    return Rotation.from_quat(random_unit_quaternion(rng), scalar_first=True).as_matrix()


def random_tumbling_bodies(rng: np.random.Generator, count: int, spin_rate: float,
                           prefix: str = "b", mass: float = 1.0) -> dict[str, dict[str, Any]]:
    """``count`` torque-free bodies with random moments, orientation and velocity.

    Each body's angular velocity has magnitude ``spin_rate`` (rad/s) in a random direction;
    its linear velocity is random (m/s). Names are ``f"{prefix}{i}"``.
    """
    bodies = {}
    for i in range(count):
        w_W = rng.normal(size=3)
        w_W *= spin_rate / np.linalg.norm(w_W)
        bodies[f"{prefix}{i}"] = {
            "mass": mass,
            "inertia": {"principal": random_principal_moments(rng).tolist()},
            "pose": {
                "position": rng.normal(size=3).tolist(),
                "orientation": quat_xyzw_from_wxyz(random_unit_quaternion(rng)).tolist(),
            },
            "twist": {"linear": rng.normal(size=3).tolist(), "angular": w_W.tolist()},
        }
    return bodies


def orientations_wxyz(sim: Simulator) -> np.ndarray:
    """The body-frame orientations the simulator reports, converted to (w, x, y, z), (N, 4)."""
    return quat_wxyz_from_xyzw(sim.orientations_xyzw())


def loglog_slope(h: np.ndarray, error: np.ndarray) -> float:
    """Least-squares slope of log(error) against log(h): the observed order of convergence."""
    slope, _intercept = np.polyfit(np.log(np.asarray(h, dtype=float)), np.log(np.asarray(error, dtype=float)), 1)
    return float(slope)


def free_bodies_scene(n: int, seed: int = 0) -> dict:
    """``n`` free asymmetric bodies at distinct poses, spinning and moving, no gravity (a scene dict)."""
    rng = np.random.default_rng(seed)
    bodies = {}
    for k in range(n):
        q = rng.normal(size=4)
        q /= np.linalg.norm(q)
        bodies[f"b{k}"] = {"mass": float(1.0 + rng.random()),
                           "inertia": {"box": [float(0.5 + rng.random()), float(0.3 + rng.random()), float(0.2 + rng.random())]},
                           "pose": {"position": rng.normal(size=3).tolist(), "orientation": q.tolist()},
                           "twist": {"linear": rng.normal(size=3).tolist(), "angular": (3 * rng.normal(size=3)).tolist()}}
    return {"bodies": bodies}


#: Hypothesis settings of the property tests: reproducible (``derandomize=True``, no example
#: database), so CI runs the same examples every time.
PROPERTY_SETTINGS = settings(max_examples=50, deadline=None, derandomize=True, database=None,
                             suppress_health_check=[HealthCheck.too_slow])


@st.composite
def valid_bodies(draw: st.DrawFn) -> dict[str, Any]:
    """A hypothesis strategy: a valid body with principal moments over six decades that satisfy the
    triangle inequality (down to thin rods and flat plates), a mass from 1e-6 to 1e6 kg, any
    orientation and velocity. Drawn as ``{"body": scene-file body, "moments": (3,) kg·m², "rng": Generator}``."""
    scale = 10.0 ** draw(st.floats(-3.0, 3.0))
    a = scale * 10.0 ** draw(st.floats(-6.0, 0.0))  # down to 1e-6 of the largest: rods and plates
    b = scale * 10.0 ** draw(st.floats(-6.0, 0.0))
    # the third between |a − b| and a + b (a degenerate plate at either end is still a body)
    c = abs(a - b) + draw(st.floats(1e-3, 1.0)) * (a + b - abs(a - b))
    moments = np.array([a, b, c])[list(draw(st.permutations([0, 1, 2])))]
    mass = 10.0 ** draw(st.floats(-6.0, 6.0))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    q = rng.normal(size=4)
    q /= np.linalg.norm(q)
    body = {
        "mass": mass,
        "inertia": {"principal": moments.tolist()},
        "pose": {"position": rng.normal(scale=10.0, size=3).tolist(), "orientation": quat_xyzw_from_wxyz(q).tolist()},
        "twist": {"linear": rng.normal(size=3).tolist(), "angular": rng.normal(size=3).tolist()},
    }
    return {"body": body, "moments": moments, "rng": rng}


def with_spin_step(spec: dict[str, Any], spin_step: float, dt: float) -> dict[str, Any]:
    """The body of a :func:`valid_bodies` draw, its angular velocity rescaled to |ω| dt = spin_step (rad)."""
    body = dict(spec["body"])
    w = np.array(body["twist"]["angular"])
    body["twist"] = {"linear": body["twist"]["linear"], "angular": (w * spin_step / (np.linalg.norm(w) * dt)).tolist()}
    return body


def seeded_noise_readings(seed: int, site: str, accelerometer: dict, gyroscope: dict, dt: float,
                          n: int) -> tuple[np.ndarray, np.ndarray]:
    """The first ``n`` (specific force, angular velocity) readings, (n, 3) each, of an IMU reading 0 whose
    channels have these ``noise_density`` and ``bias`` and whose stream is seeded ``seed`` at ``site``
    (core.imu.ImuNoise at interval ``dt``): what the node and the CLI must write for it."""
    from rigid_body_sim.core.imu import ImuChannel, ImuNoise, ImuSpec

    def channel(spec: dict) -> ImuChannel:
        return ImuChannel(noise_density=spec["noise_density"], bias=tuple(spec["bias"]))

    noise = ImuNoise(ImuSpec(seed=seed, accelerometer=channel(accelerometer), gyroscope=channel(gyroscope)), site)
    readings = [noise.sample(np.zeros(3), np.zeros(3), dt) for _ in range(n)]
    return np.array([r[0] for r in readings]), np.array([r[1] for r in readings])


def assert_white_noise(samples: np.ndarray, bias: Any, sigma: float, standard_errors: float = 4.5) -> None:
    """Per axis, the samples (n, 3) have mean ``bias`` and standard deviation ``sigma``, each within
    ``standard_errors`` of its standard error: σ/√n for the mean, σ/√(2(n − 1)) for the standard
    deviation of Gaussian samples (4.5 of them: a false alarm about once in 10⁵ seeds)."""
    n = len(samples)
    np.testing.assert_allclose(samples.mean(axis=0), bias, rtol=0, atol=standard_errors * sigma / np.sqrt(n))
    np.testing.assert_allclose(samples.std(axis=0, ddof=1), sigma, rtol=standard_errors / np.sqrt(2 * (n - 1)))
# ------------------------------------------------------------------ node processes and their stops


def write_tumbling_scene(path: Path, count: int, seed: int = 0) -> Path:
    """Write a scene of ``count`` torque-free tumbling bodies (b0, b1, ...) to ``path``; return it."""
    bodies = random_tumbling_bodies(np.random.default_rng(seed), count, spin_rate=2.0)
    path.write_text(yaml.safe_dump({"bodies": bodies}))
    return path


def wait_for_line(log_path: Path, text: str, process: subprocess.Popen, timeout: float) -> float:
    """Wait until ``text`` is in the log of a running ``process``; return when it was seen (monotonic s)."""
    deadline = time.monotonic() + timeout
    while text not in log_path.read_text():
        assert process.poll() is None, f"exited {process.returncode} before {text!r}:\n{log_path.read_text()[-2000:]}"
        assert time.monotonic() < deadline, f"{text!r} not logged within {timeout} s:\n{log_path.read_text()[-2000:]}"
        time.sleep(0.02)
    return time.monotonic()


def own_shared_memory(pid: int) -> set[Path]:
    """The Fast DDS segments process ``pid`` owns in /dev/shm, with their lock files: those whose
    ``_el`` lock file it keeps open (the shared port segments left out)."""
    paths = set()
    try:
        fds = list(Path(f"/proc/{pid}/fd").iterdir())
    except OSError:
        return paths
    for fd in fds:
        try:
            path = Path(os.readlink(fd))
        except OSError:
            continue
        if path.parent == Path("/dev/shm") and path.name.startswith("fastdds_") and path.name.endswith("_el") \
                and not path.name.startswith("fastdds_port"):
            paths |= {path, path.with_name(path.name.removesuffix("_el"))}
    return paths


def wait_for_participant(process: subprocess.Popen, timeout: float = 120.0) -> float:
    """Wait until ``process`` has created its DDS participant (it owns a Fast DDS segment);
    return when that was seen (monotonic s)."""
    deadline = time.monotonic() + timeout
    while not own_shared_memory(process.pid):
        assert process.poll() is None, f"exited {process.returncode} before creating a participant"
        assert time.monotonic() < deadline, f"no participant within {timeout} s"
        time.sleep(0.02)
    return time.monotonic()


def stop_and_check(process: subprocess.Popen, signum: signal.Signals, log_path: Path,
                   record: Path | None = None, what: str = "", timeout: float = 60.0) -> float:
    """Send ``signum``: the process must exit 0 with no traceback and leave no Fast DDS segment of
    its own in /dev/shm; a recording, if there is one, must be complete. Returns the seconds from
    the signal to the exit."""
    segments = own_shared_memory(process.pid)
    sent = time.monotonic()
    process.send_signal(signum)
    try:
        code = process.wait(timeout=timeout)
    except subprocess.TimeoutExpired:
        process.kill()
        process.wait()
        raise AssertionError(f"{what}: no exit within {timeout} s of {signum.name}:\n{log_path.read_text()[-2000:]}")
    took = time.monotonic() - sent
    text = log_path.read_text()
    assert code == 0, f"{what}: {signum.name} -> exit {code}:\n{text[-2000:]}"
    assert "Traceback" not in text and "KeyboardInterrupt" not in text and "Error" not in text, f"{what}:\n{text[-2000:]}"
    left = sorted(str(path) for path in segments if path.exists())
    assert not left, f"{what}: left in /dev/shm: {left}"
    if record is not None and record.exists():
        from rigid_body_sim.offline.recording import read_recording

        data, _scene = read_recording(record)
        assert data.meta.get("status", "").startswith("complete"), f"{what}: recording {data.meta.get('status')!r}"
    return took


def kill_if_running(*processes: subprocess.Popen) -> None:
    """SIGKILL what still runs (the end of a test that failed half-way)."""
    for process in processes:
        if process.poll() is None:
            process.kill()
            process.wait()
