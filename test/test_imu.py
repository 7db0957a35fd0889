"""IMU models on sites (core/imu.py): the scene's ``imu:`` form and the noise statistics against their parameters.

The noise model is the discrete one of Kalibr/Gazebo: white noise of standard deviation
σ_n/√Δt per sample, a turn-on bias, and a bias that walks by σ_b·√Δt·N(0, 1) per sample. With
n = 2·10⁴ samples the sample standard deviation is within 4.5·σ/√(2n) ≈ 2.3 % of σ (4.5 standard
errors), inside the 5 % asked; the biases are chosen so that 5 % of each is at least 4.5 standard
errors σ/√n of the sample mean (|b| ≥ 90 σ/√n), so the mean's check is as strict.
"""

from __future__ import annotations

import numpy as np
import pytest

from helpers import assert_white_noise, scene_of, seeded_noise_readings
from rigid_body_sim.core import SceneError, Simulator, load_scene
from rigid_body_sim.core.imu import ImuBank, ImuChannel, ImuNoise, ImuSpec

N_SAMPLES = 20_000


def _scene(imu: object) -> dict:
    return {"bodies": {"b": {"mass": 1.0, "inertia": {"sphere": 0.1},
                             "sites": {"s": {"position": [0.0, 0.0, 0.0], "imu": imu}}}}}


def test_empty_imu_is_ideal_and_keys_are_read() -> None:
    assert load_scene(_scene({})).imus["b/s"] == ImuSpec()
    spec = load_scene(_scene({"rate": 50, "seed": 3, "orientation": False,
                              "accelerometer": {"noise_density": 0.01, "bias": [0.1, 0.2, 0.3], "bias_random_walk": 1e-3},
                              "gyroscope": {"bias": 0.5}})).imus["b/s"]
    assert spec == ImuSpec(rate=50.0, seed=3, orientation=False,
                           accelerometer=ImuChannel(0.01, (0.1, 0.2, 0.3), 1e-3), gyroscope=ImuChannel(0.0, (0.5,) * 3, 0.0))


@pytest.mark.parametrize("imu, where, expected", [
    ({"rate": 0}, "bodies.b.sites.s.imu.rate", "> 0"),
    ({"seed": -1}, "bodies.b.sites.s.imu.seed", "an integer"),
    ({"seed": 1.5}, "bodies.b.sites.s.imu.seed", "an integer"),
    ({"orientation": "yes"}, "bodies.b.sites.s.imu.orientation", "true or false"),
    ({"gyro": {}}, "bodies.b.sites.s.imu.gyro", "unknown key"),
    ({"accelerometer": {"noise_density": -1}}, "bodies.b.sites.s.imu.accelerometer.noise_density", "≥ 0"),
    ({"accelerometer": {"bias": [1, 2]}}, "bodies.b.sites.s.imu.accelerometer.bias", "3 finite numbers"),
    ({"gyroscope": {"bias_random_walk": float("nan")}}, "bodies.b.sites.s.imu.gyroscope.bias_random_walk", "finite"),
    ([1, 2], "bodies.b.sites.s.imu", "a mapping"),
])
def test_bad_imu_keys_name_the_key_path(imu: object, where: str, expected: str) -> None:
    with pytest.raises(SceneError, match=expected) as info:
        load_scene(_scene(imu))
    assert where in str(info.value)


def test_describe_lists_imus() -> None:
    from rigid_body_sim.core import describe_scene

    sites = describe_scene(load_scene(_scene({"rate": 50.0, "gyroscope": {"bias": 0.5}})))[0]["sites"]
    assert sites[0]["imu"] == {"rate": 50.0, "seed": 0, "orientation": True, "accelerometer": None,
                               "gyroscope": {"noise_density": 0.0, "bias": [0.5, 0.5, 0.5], "bias_random_walk": 0.0}}


def test_white_noise_and_bias_match_their_parameters() -> None:
    """Mean = bias, standard deviation = σ_n/√Δt, per axis, over 2·10⁴ samples (within 5 %)."""
    dt = 0.005
    accel = ImuChannel(noise_density=0.02, bias=(0.3, -0.2, 0.5))
    gyro = ImuChannel(noise_density=0.003, bias=(0.05, 0.04, -0.06))
    noise = ImuNoise(ImuSpec(seed=11, accelerometer=accel, gyroscope=gyro), "b/s")
    ideal_f, ideal_w = np.array([0.0, 0.0, 9.81]), np.array([1.0, -2.0, 0.5])
    samples = [noise.sample(ideal_f, ideal_w, dt) for _ in range(N_SAMPLES)]
    f = np.array([s[0] for s in samples]) - ideal_f
    w = np.array([s[1] for s in samples]) - ideal_w
    for got, channel in ((f, accel), (w, gyro)):
        sigma = channel.noise_density / np.sqrt(dt)
        np.testing.assert_allclose(got.mean(axis=0), channel.bias, rtol=0.05)
        np.testing.assert_allclose(got.std(axis=0, ddof=1), sigma, rtol=0.05)
        assert ImuNoise.variance(channel, dt) == pytest.approx(sigma**2, rel=1e-12)


def test_bias_random_walk_increments_match_their_parameter() -> None:
    """Without white noise a reading's change from one sample to the next is the bias step: mean 0,
    standard deviation σ_b·√Δt."""
    dt, walk = 0.01, 0.004
    noise = ImuNoise(ImuSpec(seed=5, accelerometer=ImuChannel(bias_random_walk=walk),
                             gyroscope=ImuChannel(bias_random_walk=walk / 10)), "b/s")
    samples = [noise.sample(np.zeros(3), np.zeros(3), dt) for _ in range(N_SAMPLES + 1)]
    for index, sigma_b in ((0, walk), (1, walk / 10)):
        steps = np.diff(np.array([s[index] for s in samples]), axis=0)
        sigma = sigma_b * np.sqrt(dt)
        assert np.all(np.abs(steps.mean(axis=0)) < 4.5 * sigma / np.sqrt(N_SAMPLES))
        np.testing.assert_allclose(steps.std(axis=0, ddof=1), sigma, rtol=0.05)


def test_seeded_noise_repeats_and_differs_per_site() -> None:
    spec = ImuSpec(seed=2, accelerometer=ImuChannel(noise_density=0.1))
    a = [ImuNoise(spec, "b/s").sample(np.zeros(3), np.zeros(3), 0.01)[0] for _ in range(2)]
    np.testing.assert_array_equal(a[0], a[1])
    other = ImuNoise(spec, "b/t").sample(np.zeros(3), np.zeros(3), 0.01)[0]
    assert not np.array_equal(a[0], other)


def test_bank_rate_samples_on_its_own_schedule_and_reports_covariances() -> None:
    """rate 25 Hz on 100 Hz steps: every 4th step; covariance σ_n²·rate on the diagonal; no orientation → −1."""
    scene = scene_of({"b": {"mass": 1.0, "inertia": {"sphere": 0.1}, "sites": {
        "fast": {"position": [0.0, 0.0, 0.0], "imu": {}},
        "slow": {"position": [0.0, 0.0, 0.0],
                 "imu": {"rate": 25.0, "orientation": False, "gyroscope": {"noise_density": 0.01}}}}}})
    sim = Simulator(scene, "rk4", 0.01)
    bank = ImuBank(scene.imus)
    counts = {"b/fast": 0, "b/slow": 0}
    for _ in range(40):
        sim.step()
        for sample in bank.sample(sim, 0.01):
            counts[sample.site] += 1
            if sample.site == "b/slow":
                assert sample.orientation_xyzw is None and sample.covariances[0][0] == -1.0
                assert sample.covariances[1][0] == pytest.approx(0.01**2 * 25.0, rel=1e-12)
                assert sample.covariances[2] == (0.0,) * 9
            else:
                assert sample.covariances == ((0.0,) * 9,) * 3
    assert counts == {"b/fast": 40, "b/slow": 10}


@pytest.mark.parametrize("duration_s", [1, pytest.param(100, marks=pytest.mark.slow)])
def test_offline_run_writes_imu_samples_whose_noise_matches_the_parameters(tmp_path, duration_s: int) -> None:
    """``rigid-body-sim run --imu-csv``: samples of a noisy IMU at the COM of a body in free fall
    (ideal specific force 0, rate 0) every 10 ms are the site's seeded noise stream at Δt = 10 ms
    (ImuNoise, as written: 1e-9); in the slow run, over 10⁴ samples, per axis, mean = bias and
    standard deviation = σ_n/√Δt within 4.5 of their standard errors (helpers.assert_white_noise);
    a second, ideal IMU 1 m off a spin ω about z reads the centripetal −ω² r exactly; the recording
    carries the same samples as sensor_msgs/Imu."""
    import csv

    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    from rigid_body_sim.cli import main

    dt, w_z = 0.01, 2.0
    accel = {"noise_density": 0.02, "bias": [0.3, -0.2, 0.5]}
    gyro = {"noise_density": 0.003, "bias": [0.05, 0.04, -0.06]}
    scene = tmp_path / "fall.yaml"
    import yaml

    scene.write_text(yaml.safe_dump({"gravity": [0.0, 0.0, -9.81], "bodies": {
        "b": {"mass": 1.0, "inertia": {"sphere": 0.1},
              "sites": {"s": {"position": [0.0, 0.0, 0.0], "imu": {"seed": 1, "accelerometer": accel, "gyroscope": gyro}}}},
        "spin": {"mass": 2.0, "inertia": {"box": [1.0, 0.6, 0.4]}, "twist": {"angular": [0.0, 0.0, w_z]},
                 "sites": {"arm": {"position": [1.0, 0.0, 0.0], "imu": {}}}}}}))
    out, rec = tmp_path / "imu.csv", tmp_path / "run.mcap"
    n = round(duration_s / dt)
    assert main(["run", str(scene), "-T", str(duration_s), "--dt", str(dt), "--imu-csv", str(out), "--record", str(rec),
                 "-q"]) == 0
    with open(out) as f:
        rows = list(csv.DictReader(line for line in f if not line.startswith("#")))
    noisy = [r for r in rows if r["site"] == "b/s"]
    assert len(noisy) == n
    f = np.array([[float(r[k]) for k in ("ax", "ay", "az")] for r in noisy])
    w = np.array([[float(r[k]) for k in ("gx", "gy", "gz")] for r in noisy])
    expected_f, expected_w = seeded_noise_readings(1, "b/s", accel, gyro, dt, n)
    np.testing.assert_allclose(f, expected_f, rtol=0, atol=1e-9)
    np.testing.assert_allclose(w, expected_w, rtol=0, atol=1e-9)
    if n >= 10_000:  # the statistics: test-slow
        for got, channel in ((f, accel), (w, gyro)):
            assert_white_noise(got, channel["bias"], channel["noise_density"] / np.sqrt(dt))
    arm = [r for r in rows if r["site"] == "spin/arm"]
    assert len(arm) == n
    for r in arm[::max(1, n // 10)]:
        np.testing.assert_allclose([float(r[k]) for k in ("ax", "ay", "az", "gx", "gy", "gz")],
                                   [-w_z**2, 0.0, 0.0, 0.0, 0.0, w_z], rtol=0, atol=1e-9)
    with open(rec, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        imu_msgs = [m for _, _, _, m in reader.iter_decoded_messages(topics=["/spin/arm/imu"])]
    assert len(imu_msgs) == n
    last = imu_msgs[-1]
    assert last.header.frame_id == "spin/arm"
    np.testing.assert_allclose([last.linear_acceleration.x, last.angular_velocity.z], [-w_z**2, w_z], rtol=0, atol=1e-9)
    assert float(arm[-1]["t"]) == pytest.approx(duration_s)
