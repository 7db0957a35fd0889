"""The ``rigid-body-sim`` command: each subcommand, its outputs, its errors and exit codes.

Most tests call :func:`rigid_body_sim.cli.main` in-process (argparse exits through
``SystemExit``); one runs the installed console script, and one checks in a fresh interpreter
that an offline run never imports ROS. Outputs are checked against the core stepped directly.
"""

from __future__ import annotations

import io
import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

from rigid_body_sim import cli
from rigid_body_sim.cli import main
from rigid_body_sim.core import Simulator, describe_scene, load_scene
from rigid_body_sim.offline.csv_io import COLUMNS, read_csv
from rigid_body_sim.package_data import default_scene_path

REPO = Path(__file__).resolve().parents[1]
PHONE = REPO / "config" / "tumbling_phone.yaml"
PNG_MAGIC = b"\x89PNG\r\n\x1a\n"

TWO_BODIES = {
    "gravity": [0.0, 0.0, -9.81],
    "bodies": {
        "box": {"mass": 2.0, "inertia": {"box": [1.0, 0.6, 0.4]}, "twist": {"angular": [0.2, 0.1, 0.5]},
                "sites": {"corner": {"position": [0.5, 0.3, 0.0]}}},
        "ball": {"mass": 1.0, "inertia": {"sphere": 0.1}, "twist": {"linear": [1.0, 0.0, 2.0]}},
    },
    "wrenches": [{"body": "box", "frame": "box/corner", "force": [0.0, 10.0, 0.0], "start": 0.05, "duration": 0.1}],
}


@pytest.fixture
def two_bodies(tmp_path: Path) -> Path:
    path = tmp_path / "two.yaml"
    path.write_text(yaml.safe_dump(TWO_BODIES, sort_keys=False), encoding="utf-8")
    return path


@pytest.fixture
def bad_scene(tmp_path: Path) -> Path:
    path = tmp_path / "bad.yaml"
    path.write_text("bodies:\n  crate:\n    mass: -1.0\n    inertia: {sphere: 0.1}\n", encoding="utf-8")
    return path


def usage_error(capsys: pytest.CaptureFixture[str], argv: list[str]) -> str:
    """Run ``argv`` expecting argparse's exit code 2; return stderr."""
    with pytest.raises(SystemExit) as info:
        main(argv)
    assert info.value.code == 2
    err = capsys.readouterr().err
    assert err.startswith("usage: rigid-body-sim")
    return err


# --------------------------------------------------------------------------- check


def test_check_ok(capsys: pytest.CaptureFixture[str], two_bodies: Path) -> None:
    assert main(["check", str(two_bodies)]) == 0
    assert capsys.readouterr().out == f"{two_bodies}: ok (2 bodies: box, ball; 1 scripted wrench)\n"


def test_check_bad_scene_prints_the_loaders_message(capsys: pytest.CaptureFixture[str], bad_scene: Path) -> None:
    assert main(["check", str(bad_scene)]) == 1
    captured = capsys.readouterr()
    assert captured.out == ""
    assert captured.err == f"rigid-body-sim check: {bad_scene}: bodies.crate.mass: expected a number > 0 (kg), got -1.0\n"


def test_check_missing_file(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    assert main(["check", str(tmp_path / "nope.yaml")]) == 1
    assert "nope.yaml: cannot read scene file" in capsys.readouterr().err


@pytest.mark.parametrize("argv", [[], ["check"], ["check", "a.yaml", "b.yaml"], ["frobnicate"], ["check", "--json", "x"]],
                         ids=["no-command", "no-scene", "two-scenes", "unknown-command", "unknown-option"])
def test_bad_arguments_exit_2(capsys: pytest.CaptureFixture[str], argv: list[str]) -> None:
    err = usage_error(capsys, argv)
    assert "error:" in err


# --------------------------------------------------------------------------- describe


def test_describe_text(capsys: pytest.CaptureFixture[str], two_bodies: Path) -> None:
    assert main(["describe", str(two_bodies)]) == 0
    out = capsys.readouterr().out
    assert out.startswith(f"scene {two_bodies}: 2 bodies, gravity [0, 0, -9.81] m/s², 1 scripted wrench\n")
    assert "\nbox: full model (motion: free)\n  why                the integrator (asymmetric inertia" in out
    assert "\nball: isotropic model (motion: free)\n  why                isotropic inertia" in out
    assert "  mass               2 kg\n" in out
    assert f"  principal moments  [{2 * (0.36 + 0.16) / 12:.6g}, {2 * (1 + 0.16) / 12:.6g}, {2 * (1 + 0.36) / 12:.6g}] kg·m²" in out
    assert "  principal axes     e1 = [1, 0, 0], e2 = [0, 1, 0], e3 = [0, 0, 1] (in body axes)" in out
    assert "  sites              corner at [0.5, 0.3, 0] m (body axes)" in out
    assert "  wrench frames      world, box, box/world_aligned, box/corner" in out
    assert "  scripted wrench    in box/corner: force [0, 10, 0] N, torque [0, 0, 0] N·m, t in [0.05, 0.15) s" in out
    assert "  sites              none" in out


def test_describe_json_is_describe_scene(capsys: pytest.CaptureFixture[str], two_bodies: Path) -> None:
    assert main(["describe", "--json", str(two_bodies)]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["scene"] == str(two_bodies) and data["gravity"] == [0.0, 0.0, -9.81]
    assert data["bodies"] == describe_scene(load_scene(two_bodies))
    assert [(b["name"], b["model"]) for b in data["bodies"]] == [("box", "full"), ("ball", "isotropic")]


def test_describe_without_reduction_gives_every_free_body_the_full_model(
        capsys: pytest.CaptureFixture[str], two_bodies: Path) -> None:
    assert main(["describe", "--json", "--no-reduction", str(two_bodies)]) == 0
    bodies = json.loads(capsys.readouterr().out)["bodies"]
    assert [b["model"] for b in bodies] == ["full", "full"]
    assert all("reduction off" in b["model_reason"] for b in bodies)


def test_describe_rotated_tensor_reports_principal_axes(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    """A tensor with a product of inertia about z: principal axes at ±45° in the x–y plane."""
    path = tmp_path / "tensor.yaml"
    path.write_text(yaml.safe_dump({"bodies": {"plate": {"mass": 1.0, "inertia": {"tensor": [[2.0, 0.5, 0.0], [0.5, 2.0, 0.0], [0.0, 0.0, 3.0]]}}}}))
    assert main(["describe", "--json", str(path)]) == 0
    body = json.loads(capsys.readouterr().out)["bodies"][0]
    moments = np.array(body["principal_moments"])
    axes = np.array(body["principal_axes_B"])
    tensor = np.array(body["inertia_B"])
    for moment, axis in zip(moments, axes):
        np.testing.assert_allclose(tensor @ axis, moment * axis, atol=1e-14)
    np.testing.assert_allclose(sorted(moments), [1.5, 2.5, 3.0], atol=1e-14)
    np.testing.assert_allclose(tensor, [[2.0, 0.5, 0.0], [0.5, 2.0, 0.0], [0.0, 0.0, 3.0]], atol=1e-14)


def test_describe_bad_scene(capsys: pytest.CaptureFixture[str], bad_scene: Path) -> None:
    assert main(["describe", str(bad_scene)]) == 1
    assert "bodies.crate.mass: expected a number > 0" in capsys.readouterr().err


# --------------------------------------------------------------------------- run


def test_run_writes_the_simulated_samples_and_a_summary(capsys: pytest.CaptureFixture[str], two_bodies: Path,
                                                        tmp_path: Path) -> None:
    out = tmp_path / "run.csv"
    assert main(["run", str(two_bodies), "--duration", "0.3", "--dt", "0.01", "--rate", "50", "--csv", str(out),
                 "--integrator", "splitting"]) == 0
    captured = capsys.readouterr()
    assert captured.err == ""  # not a terminal: no progress bar
    lines = captured.out.splitlines()
    assert lines[0] == f"{two_bodies}: integrator splitting, dt = 0.01 s"
    assert lines[1] == "  steps               30 (sim time 0.3 s)"
    assert lines[2].startswith("  wall time ") and lines[3].startswith("  real-time factor ")
    assert lines[4].startswith("  box: energy ") and "drift max |E-E0|/|E0| = " in lines[4] and "|L| " in lines[4]
    assert lines[-1] == f"  wrote {out} (16 samples)"

    data = read_csv(out)
    assert data.meta["integrator"] == "splitting" and data.meta["dt"] == "0.01"
    assert Path(data.meta["scene"]) == two_bodies.resolve()
    sim = Simulator(load_scene(two_bodies), "splitting", 0.01)
    for k in range(16):
        assert data.time[k] == sim.time
        for b, body in enumerate(sim.body_names):
            track = data.bodies[body]
            s = sim.body_state(body)
            np.testing.assert_array_equal(track.position_world[k], s.position_world)
            np.testing.assert_array_equal(track.orientation_xyzw[k], s.orientation_xyzw)
            np.testing.assert_array_equal(track.linear_velocity_world[k], s.linear_velocity_world)
            np.testing.assert_array_equal(track.angular_velocity_world[k], s.angular_velocity_world)
            np.testing.assert_array_equal(track.angular_velocity_body[k], s.angular_velocity_body)
            assert track.energy[k] == (sim.kinetic_energy() + sim.potential_energy())[b]
            # The writer's own expression: a 1-D norm (a BLAS dot) may differ from it in the last bit.
            assert track.angular_momentum_norm[k] == np.linalg.norm(sim.angular_momentum(), axis=1)[b]
        sim.step(2)


def test_run_csv_header_names_every_column(two_bodies: Path, tmp_path: Path) -> None:
    out = tmp_path / "run.csv"
    assert main(["run", str(two_bodies), "-T", "0.02", "--csv", str(out), "-q"]) == 0
    lines = out.read_text().splitlines()
    comments = [line for line in lines if line.startswith("#")]
    assert any(line.startswith("# columns: t [s]; per body B: B.px B.py B.pz [m, world]") for line in comments)
    assert lines[-1] == "# status: complete: 2 steps, t = 0.02 s"  # how the run ended, after the rows
    header = next(line for line in lines if not line.startswith("#")).split(",")
    assert header == ["t"] + [f"{b}.{c}" for b in ("box", "ball") for c in COLUMNS]
    with open(out, encoding="utf-8") as f:  # as the module docstring tells numpy users
        table = np.genfromtxt((line for line in f if not line.startswith("#")), delimiter=",", names=True,
                              deletechars="")
    assert table["box.qw"].tolist() == read_csv(out).bodies["box"].orientation_xyzw[:, 3].tolist()
    assert table["t"].tolist() == [0.0, 0.01, 0.02]


def test_run_quiet_prints_nothing(capsys: pytest.CaptureFixture[str], two_bodies: Path) -> None:
    assert main(["run", str(two_bodies), "--duration", "0.05", "--quiet"]) == 0
    assert capsys.readouterr() == ("", "")


def test_run_duration_is_rounded_up_to_whole_steps(capsys: pytest.CaptureFixture[str], two_bodies: Path) -> None:
    assert main(["run", str(two_bodies), "--duration", "0.025", "--dt", "0.01"]) == 0
    assert "  steps               3 (sim time 0.03 s)" in capsys.readouterr().out


class _FakeTerminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_progress_bar_on_a_terminal_only(monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str],
                                         two_bodies: Path) -> None:
    monkeypatch.setattr(cli, "PROGRESS_DELAY_S", 0.0)
    terminal = _FakeTerminal()
    monkeypatch.setattr(sys, "stderr", terminal)
    assert main(["run", str(two_bodies), "--duration", "0.5"]) == 0
    assert "simulating:" in terminal.getvalue() and "/50.0 [" in terminal.getvalue()
    assert "steps               50" in capsys.readouterr().out  # the summary still goes to stdout
    terminal = _FakeTerminal()
    monkeypatch.setattr(sys, "stderr", terminal)
    assert main(["run", str(two_bodies), "--duration", "0.5", "--quiet"]) == 0
    assert terminal.getvalue() == ""


@pytest.mark.parametrize(("argv", "message"), [
    (["run", "S"], "the following arguments are required: --duration"),
    (["run", "S", "--duration", "-1"], "argument --duration/-T: expected a finite number > 0 (s of sim time), got '-1'"),
    (["run", "S", "--duration", "nan"], "argument --duration/-T: expected a finite number > 0"),
    (["run", "S", "--duration", "ten"], "argument --duration/-T: expected a number (s of sim time), got 'ten'"),
    (["run", "S", "-T", "1", "--dt", "0"], "argument --dt: expected a finite number > 0 (s), got '0'"),
    (["run", "S", "-T", "1", "--rate", "inf"], "argument --rate: expected a finite number > 0"),
    (["run", "S", "-T", "1", "--integrator", "verlet"], "argument --integrator: invalid choice: 'verlet' (choose from"),
    (["run", "S", "-T", "1", "--csv", "/nonexistent_dir_rbs/out.csv"], "argument --csv: directory '/nonexistent_dir_rbs'"),
    (["run", "S", "-T", "1", "--record", "/nonexistent_dir_rbs/out.mcap"], "argument --record: directory '/nonexistent_dir_rbs'"),
    (["run"], "the following arguments are required: SCENE, --duration"),
])
def test_run_bad_arguments_exit_2(capsys: pytest.CaptureFixture[str], argv: list[str], message: str) -> None:
    err = usage_error(capsys, argv)
    assert f"rigid-body-sim {argv[0]}: error: {message}" in err


def test_run_bad_scene_exits_1_with_the_loaders_message(capsys: pytest.CaptureFixture[str], bad_scene: Path,
                                                         tmp_path: Path) -> None:
    out = tmp_path / "never.csv"
    assert main(["run", str(bad_scene), "--duration", "1", "--csv", str(out)]) == 1
    assert capsys.readouterr().err == (
        f"rigid-body-sim run: {bad_scene}: bodies.crate.mass: expected a number > 0 (kg), got -1.0\n")
    assert not out.exists()


def test_run_that_blows_up_exits_1_and_keeps_the_samples(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    """Explicit Euler on a fast asymmetric spin: a non-finite state or blow-up is reported, files closed."""
    scene = tmp_path / "fast.yaml"
    scene.write_text(yaml.safe_dump({"bodies": {"plate": {"mass": 1.0, "inertia": {"principal": [1.0, 2.0, 2.9]},
                                                          "twist": {"angular": [300.0, 300.0, 300.0]}}}}))
    out = tmp_path / "fast.csv"
    code = main(["run", str(scene), "--duration", "100", "--dt", "0.1", "--integrator", "euler", "--csv", str(out)])
    assert code == 1
    err = capsys.readouterr().err
    assert err.startswith("rigid-body-sim run: ") and "with integrator 'euler'" in err and "files written" in err
    assert len(read_csv(out).time) >= 1


# --------------------------------------------------------------------------- plot


def test_plot_csv_and_mcap(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    csv_path, mcap_path = tmp_path / "phone.csv", tmp_path / "phone.mcap"
    assert main(["run", str(PHONE), "-T", "1", "--csv", str(csv_path), "--record", str(mcap_path), "-q"]) == 0
    assert main(["plot", str(csv_path)]) == 0
    assert main(["plot", str(mcap_path), "-o", str(tmp_path / "from_mcap.png")]) == 0
    out = capsys.readouterr().out
    assert out == f"wrote {tmp_path / 'phone.png'}\nwrote {tmp_path / 'from_mcap.png'}\n"
    for png in (tmp_path / "phone.png", tmp_path / "from_mcap.png"):
        assert png.read_bytes()[:8] == PNG_MAGIC and png.stat().st_size > 50_000


def test_plot_one_file_per_body_and_body_choice(capsys: pytest.CaptureFixture[str], two_bodies: Path,
                                                 tmp_path: Path) -> None:
    csv_path = tmp_path / "two.csv"
    assert main(["run", str(two_bodies), "-T", "0.2", "--csv", str(csv_path), "-q"]) == 0
    assert main(["plot", str(csv_path), "-o", str(tmp_path / "fig.png")]) == 0
    assert capsys.readouterr().out == f"wrote {tmp_path / 'fig_box.png'}\nwrote {tmp_path / 'fig_ball.png'}\n"
    assert (tmp_path / "fig_ball.png").read_bytes()[:8] == PNG_MAGIC
    assert main(["plot", str(csv_path), "--body", "crate"]) == 1
    assert "no body 'crate'; the run has ['box', 'ball']" in capsys.readouterr().err


def test_plot_errors(capsys: pytest.CaptureFixture[str], tmp_path: Path, bad_scene: Path) -> None:
    assert main(["plot", str(tmp_path / "missing.csv")]) == 1
    assert "missing.csv: cannot read the run" in capsys.readouterr().err
    garbage = tmp_path / "garbage.csv"
    garbage.write_text("a,b\n1,2\n")
    assert main(["plot", str(garbage)]) == 1
    assert "garbage.csv: expected the first column to be 't'" in capsys.readouterr().err
    err = usage_error(capsys, ["plot"])
    assert "the following arguments are required: RUN" in err
    err = usage_error(capsys, ["plot", str(garbage), "-o", "/nonexistent_dir_rbs/x.png"])
    assert "argument --output: directory '/nonexistent_dir_rbs' of '/nonexistent_dir_rbs/x.png' does not exist" in err
    csv_path = tmp_path / "ok.csv"
    assert main(["run", str(default_scene_path()), "-T", "0.02", "--csv", str(csv_path), "-q"]) == 0
    assert main(["plot", str(csv_path), "--scene", str(bad_scene)]) == 1
    assert "bodies.crate.mass: expected a number > 0" in capsys.readouterr().err


def test_plot_reference_is_the_closed_form_of_the_phone() -> None:
    """The error panel compares with closed_form.asymmetric_top: rk4 at dt = 0.01 s is within 1e-4 rad over 5 s."""
    from rigid_body_sim.core.quaternion import quat_angle_between, quat_wxyz_from_xyzw
    from rigid_body_sim.offline.reference import closed_form_reference

    scene = load_scene(PHONE)
    sim = Simulator(scene, "rk4", 0.01)
    sim.step(500)
    reference = closed_form_reference(scene, "phone", np.array([0.0, sim.time]))
    assert reference.rotation.startswith("torque-free asymmetric top")
    assert math.isclose(reference.flip_period, 3.35, abs_tol=0.005)
    angle = quat_angle_between(quat_wxyz_from_xyzw(sim.orientations_xyzw()[0]),
                               quat_wxyz_from_xyzw(reference.orientation_xyzw[1]))
    assert angle < 1e-4  # rk4's global error, O(h^4): ~1e-6 rad seen
    np.testing.assert_array_equal(reference.position_world, np.zeros((2, 3)))


# --------------------------------------------------------------------------- the console script, without ROS


def test_console_script_is_installed_and_exits_2_on_bad_arguments() -> None:
    script = Path(sys.executable).parent / "rigid-body-sim"
    assert script.exists(), "console script rigid-body-sim is not installed (pip install -e .)"
    result = subprocess.run([str(script), "run", str(PHONE), "--duration", "0"], capture_output=True, text=True,
                            timeout=60)
    assert result.returncode == 2
    assert "argument --duration/-T: expected a finite number > 0" in result.stderr
    result = subprocess.run([str(script), "check", str(PHONE)], capture_output=True, text=True, timeout=60)
    assert (result.returncode, result.stdout) == (0, f"{PHONE}: ok (1 body: phone; 0 scripted wrenches)\n")


def test_offline_run_imports_no_ros(tmp_path: Path) -> None:
    program = (
        "import json, sys\n"
        "from rigid_body_sim.cli import main\n"
        f"code = main(['run', {str(PHONE)!r}, '-T', '0.1', '--csv', {str(tmp_path / 'a.csv')!r}, "
        f"'--record', {str(tmp_path / 'a.mcap')!r}, '-q'])\n"
        f"from rigid_body_sim.offline.recording import read_recording\n"
        f"data, scene_text = read_recording({str(tmp_path / 'a.mcap')!r})\n"
        "assert list(data.bodies) == ['phone'] and scene_text\n"
        "import rigid_body_sim.offline.csv_io, rigid_body_sim.offline.plotting, rigid_body_sim.offline.reference\n"
        "import matplotlib.figure, matplotlib.backends.backend_agg  # what plot_body imports when it draws\n"
        "print(json.dumps([code, sorted(sys.modules)]))\n"
    )
    result = subprocess.run([sys.executable, "-c", program], capture_output=True, text=True, timeout=120, cwd=REPO)
    assert result.returncode == 0, result.stderr
    code, modules = json.loads(result.stdout.strip().splitlines()[-1])
    assert code == 0
    ros = [m for m in modules if m.split(".")[0] == "rclpy" or m.split(".")[0].endswith("_msgs")
           or m.split(".")[0].startswith("rcl")]
    assert not ros, f"an offline run imported ROS modules: {ros}"
    assert "mcap_ros2" in modules and "matplotlib.figure" in modules
