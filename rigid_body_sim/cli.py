"""The ``rigid-body-sim`` command: offline runs, plots, scene descriptions and checks, without ROS.

Subcommands (``rigid-body-sim SUBCOMMAND --help`` for each)::

    run SCENE --duration T [--integrator NAME] [--dt H] [--rate HZ] [--csv OUT.csv] [--record OUT.mcap] [--imu-csv OUT.csv] [-q]
    plot RUN [-o OUT.png] [--scene SCENE] [--body NAME]
    describe SCENE [--json]
    check SCENE
    view [--namespace NS] [--node NAME] [--host ADDR] [--port PORT] [--strike-body NAME]   (a live 3D view in the browser)
    view RECORDING.mcap [--host ADDR] [--port PORT]   (replay a recording in the same view, no ROS)
    shard SCENE --shards K --out DIR   (shard scenes, one node each: docs/shards.md)

Exit codes: 0 success; 1 a scene or input file that cannot be used (the message names the
file, key path and expectation), a run that failed, or an output that could not be written
to the end (a full disk); 2 bad command-line arguments (argparse's convention), including a
step or rate no run can take and outputs that cannot be written (a FIFO, a device, a
directory, a path that cannot be created, two outputs or an output and the scene on one
file); 0 when stopped by a signal, Ctrl-C (SIGINT) or SIGTERM, or when the reader of stdout
goes away (``describe ... | head``): a stop asked for is not a failure. An interrupted ``run``
closes its files properly and ends them with a status saying where it stopped (``interrupted
by SIGTERM at t = ... s``; a complete run's status says ``complete``), and says so on stderr:
the files, not the exit code, tell a cut-short run from a whole one. Before ``run`` opens its
files, and in the other commands, a signal ends the command at once (status 0, one line on
stderr; :mod:`rigid_body_sim.signals`).
No error ends in a traceback. This module only parses arguments and prints: the work is in
:mod:`rigid_body_sim.offline` and :mod:`rigid_body_sim.core`. ``check`` imports the scene
loader only (not the compiled simulator), so it is quick and small.
"""

from __future__ import annotations

import argparse
import errno
import json
import math
import os
import signal
import stat
import sys
from contextlib import ExitStack
from pathlib import Path
from typing import TYPE_CHECKING, Any, Iterator, Sequence

from .core import SceneError, load_scene
from .safe_open import check_writable_path, open_for_reading, same_file
from .signals import TwoPhaseSignals

if TYPE_CHECKING:
    from .core import Scene

__all__ = ["main", "build_parser", "DEFAULT_DT", "DEFAULT_RATE_HZ"]

PROG = "rigid-body-sim"
#: Physics step of ``run`` unless --dt says otherwise, s (the node's default: 100 Hz, 1 substep).
DEFAULT_DT = 0.01
#: Samples per sim second written to --csv and --record unless --rate says otherwise.
DEFAULT_RATE_HZ = 100.0
#: Runs expected to take longer than this (wall s) show a progress bar on a terminal.
PROGRESS_DELAY_S = 0.5
_MCAP_MAGIC = b"\x89MCAP"


class _Failure(Exception):
    """A failure to report as ``rigid-body-sim <command>: <message>`` with exit code 1."""


class _Interrupted(KeyboardInterrupt):
    """SIGINT or SIGTERM stopped a run between two samples (raised by :func:`_run`)."""

    def __init__(self, signum: int):
        super().__init__(signal.Signals(signum).name)
        self.signum = signum


class _WriteError(OSError):
    """Writing an output failed in the middle of a run (a full disk...)."""

    def __init__(self, path: Path, error: OSError):
        super().__init__(error.errno, error.strerror or str(error), str(path))


class _IntegratorNames:
    """The names of INTEGRATORS, looked up on first use (argparse ``choices``): building the
    parser must not import the compiled simulator, which ``check`` never needs."""

    def _names(self) -> list[str]:
        from .core import INTEGRATORS

        return sorted(INTEGRATORS)

    def __contains__(self, name: object) -> bool:
        return name in self._names()

    def __iter__(self) -> Iterator[str]:
        return iter(self._names())


# ------------------------------------------------------------------------------ arguments


def _positive_float(unit: str):
    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected a number ({unit}), got {text!r}") from None
        if not (math.isfinite(value) and value > 0.0):
            raise argparse.ArgumentTypeError(f"expected a finite number > 0 ({unit}), got {text!r}")
        return value

    parse.__name__ = f"number ({unit})"
    return parse


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of ``rigid-body-sim`` (all subcommands)."""
    parser = argparse.ArgumentParser(prog=PROG, description=(
        "Offline runs, plots and scene checks for rigid_body_sim (no ROS needed), and a live browser view of a running node."))
    sub = parser.add_subparsers(dest="command", required=True, metavar="{run,plot,describe,check,view,shard}")

    run = sub.add_parser("run", help="run a scene as fast as possible", description=(
        "Step SCENE for --duration seconds of sim time as fast as possible, optionally writing a CSV "
        "file and an MCAP recording, and print a summary (steps, wall time, real-time factor, energy and "
        "|L| drift). Scripted wrenches in the scene act as they would in the node."))
    run.add_argument("scene", metavar="SCENE", help="scene YAML file")
    run.add_argument("--duration", "-T", required=True, type=_positive_float("s of sim time"),
                     help="sim time to run, s (rounded up to whole steps)")
    run.add_argument("--integrator", default="rk4", choices=_IntegratorNames(), metavar="NAME",
                     help="one of %(choices)s (default rk4)")
    run.add_argument("--dt", type=_positive_float("s"), default=DEFAULT_DT, help=f"physics step, s (default {DEFAULT_DT:g})")
    run.add_argument("--threads", type=int, default=0, metavar="N",
                     help="threads the step may use over the bodies (default 0: every core; the same results "
                          "for any N)")
    run.add_argument("--rate", type=_positive_float("samples per sim second"), default=DEFAULT_RATE_HZ,
                     help=f"samples per sim second in --csv and --record (default {DEFAULT_RATE_HZ:g}; "
                          "every step if the step is longer)")
    run.add_argument("--csv", metavar="OUT.csv", help="write the samples to this CSV file (read by 'plot')")
    run.add_argument("--record", metavar="OUT.mcap",
                     help="write an MCAP recording (ROS 2 messages: /B/pose, /B/twist, /B/wrench, /clock, "
                          "and /B/S/imu for each IMU site)")
    run.add_argument("--imu-csv", metavar="OUT.csv",
                     help="write the samples of the scene's IMUs (sites with imu:) to this CSV file, one row per "
                          "sample; an IMU samples at each --rate sample, or at its own lower rate")
    run.add_argument("--quiet", "-q", action="store_true", help="no progress bar and no summary")
    run.add_argument("--no-reduction", action="store_true",
                     help="step every body with the integrator (no model reduction; for comparisons)")

    plot = sub.add_parser("plot", help="plot a run (CSV or MCAP) to PNG", description=(
        "Plot a run written by 'run --csv' or an MCAP recording (from 'run --record' or the node's "
        "record_path): position, orientation, velocities, energy and |L| drift, and the error against "
        "the closed form where the scene has one. One PNG per body."))
    plot.add_argument("run", metavar="RUN", help="a CSV file from 'run --csv', or an .mcap recording")
    plot.add_argument("--output", "-o", metavar="OUT.png",
                      help="PNG to write (default: RUN with .png; with several bodies, one OUT_<body>.png each)")
    plot.add_argument("--scene", metavar="SCENE",
                      help="the run's scene (default: the one named in the CSV, or attached to the recording)")
    plot.add_argument("--body", metavar="NAME", help="plot only this body")

    describe = sub.add_parser("describe", help="describe a scene's bodies", description=(
        "Bodies, mass properties, principal axes and moments, initial state, sites, wrench frames, scripted "
        "wrenches, and the model each body gets."))
    describe.add_argument("scene", metavar="SCENE", help="scene YAML file")
    describe.add_argument("--json", action="store_true", help="print JSON (one object per body) instead of text")
    describe.add_argument("--no-reduction", action="store_true", help="the models with model reduction off")

    check = sub.add_parser("check", help="validate a scene", description=(
        "Validate SCENE only: print a one-line summary and exit 0, or print the loader's error "
        "(file, key path, what was expected) and exit 1."))
    check.add_argument("scene", metavar="SCENE", help="scene YAML file")
    view = sub.add_parser("view", help="a live 3D view of a running node, or a recording's replay, in the browser",
                          description=(
        "Serve a live 3D view of a running rigid_body_sim node (viser; open the printed address): its bodies "
        "from 'poses' and 'markers', sim time, Pause/Run/Step/Reset, and the 'Feel the offset' strike panel. "
        "With RECORDING, replay that MCAP recording instead (no ROS): its bodies drawn from the attached scene, "
        "a time slider, Play and Pause. "
        "Needs requirements-view.txt (make venv installs it). Exit 2 if the address is in use, or if RECORDING "
        "is not a recording that can be read. See docs/view.md."))
    view.add_argument("recording", nargs="?", metavar="RECORDING",
                      help="an MCAP recording ('run --record' or the node's record_path) to replay instead of "
                           "viewing a live node")
    view.add_argument("--namespace", default="/", help="ROS namespace of the simulator's topics (default /)")
    view.add_argument("--node", default="rigid_body_sim", help="the simulator node's name (default rigid_body_sim)")
    view.add_argument("--host", default="127.0.0.1", help="address to serve on (default 127.0.0.1; 0.0.0.0 for all)")
    view.add_argument("--port", type=int, default=8080, help="port to serve on (default 8080)")
    view.add_argument("--strike-body", default="box", help="body the 'Feel the offset' panel strikes (default box)")
    shard = sub.add_parser("shard", help="split a scene into shard scenes, one node each", description=(
        "Write SCENE's bodies split into K shard scenes (contiguous blocks in scene order, each with its scripted "
        "wrenches; gravity and ground in every shard) and a manifest, shards.yaml, with the command that runs "
        "each shard as a node in its own namespace /shard_<k>. Bodies touch only the ground, never each other, "
        "so every body moves exactly as in the whole scene. See docs/shards.md."))
    shard.add_argument("scene", metavar="SCENE", help="scene YAML file")
    shard.add_argument("--shards", "-k", type=int, required=True, help="number of shards (1 to the body count)")
    shard.add_argument("--out", required=True, metavar="DIR", help="folder for shard_<k>.yaml and shards.yaml")
    for subparser in (run, plot, describe, check, view, shard):
        subparser.set_defaults(command_parser=subparser)  # so each command reports usage errors as itself
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``rigid-body-sim`` console script; returns the exit code."""
    parser = build_parser()
    args = parser.parse_args(argv)
    command = {"run": _run, "plot": _plot, "describe": _describe, "check": _check, "view": _view,
               "shard": _shard}[args.command]
    # Phase 1 (nothing written yet): a signal exits 0 at once; ``run`` switches to phase 2 before
    # it opens its outputs, so that a signal then stops it between two samples.
    args.signals = TwoPhaseSignals(f"{PROG} {args.command}", during="")
    try:
        try:
            return command(args, args.command_parser)
        except (SceneError, _Failure) as exc:
            print(f"{PROG} {args.command}: {exc}", file=sys.stderr)
            return 1
        except KeyboardInterrupt as exc:
            signum = getattr(exc, "signum", signal.SIGINT)
            closed = "; files written so far are closed and say where the run stopped" if args.command == "run" else ""
            print(f"{PROG} {args.command}: interrupted by {signal.Signals(signum).name}{closed}", file=sys.stderr)
            return 0
        except BrokenPipeError:  # stdout's reader went away (| head): stop quietly
            devnull = os.open(os.devnull, os.O_WRONLY)
            os.dup2(devnull, sys.stdout.fileno())  # so that flushing stdout at exit fails no more
            os.close(devnull)
            return 0
    finally:
        args.signals.restore()


def _view(args: argparse.Namespace, parser: argparse.ArgumentParser) -> int:
    """``view``: the work is in :mod:`rigid_body_sim.view.app`; a signal ends it in order (exit 0)."""
    if not 0 < args.port < 65536:
        parser.error(f"--port must be 1 to 65535, got {args.port}")
    try:
        from .view.app import run_view
    except ImportError as exc:
        raise _Failure(f"{exc}; install the view's pins: .venv/bin/pip install -r requirements-view.txt") from None
    stop = args.signals.switch_to_orderly()
    if args.recording is not None:
        from .view.replay import run_replay

        return run_replay(args.recording, args.host, args.port, stop)
    return run_view(args.namespace, args.node, args.host, args.port, args.strike_body, stop)


#: What a path is when looking it up fails with this errno (the lookup, not the file, is the problem).
_PATH_ERRNOS = {
    errno.ELOOP: "is a symbolic link loop (or goes through one)",
    errno.ENAMETOOLONG: "is too long a name for the file system",
    errno.ENOTDIR: "goes through something that is not a directory",
    errno.EISDIR: "is a directory",
    errno.EACCES: "cannot be reached (permission denied on a directory of it)",
    errno.EOVERFLOW: "cannot be examined (value too large)",
}


def _path_error(value: str, expected: str) -> str | None:
    """Why ``value`` cannot even be looked up as the path of ``expected`` to write (a symlink loop,
    a name too long, a component that is not a directory...), as one line naming it, or None."""
    try:
        os.stat(value)
    except FileNotFoundError:
        return None  # a new file (its directory is checked by check_writable_path)
    except ValueError:  # an embedded NUL byte
        return f"{value!r} contains a NUL byte; expected the path of {expected} to write"
    except OSError as exc:
        what = _PATH_ERRNOS.get(exc.errno or 0, f"cannot be looked up ({exc.strerror or exc})")
        return f"{value!r} {what}; expected the path of {expected} to write"
    return None


def _input_path(parser: argparse.ArgumentParser, argument: str, value: str | None, expected: str) -> None:
    """A usage error naming ``argument`` if ``value`` cannot name a file to read at all: a symlink
    loop, a name too long, a component that is not a directory, or a directory itself. A missing
    or unreadable file, a FIFO or a device stays the reader's error (exit 1)."""
    if value is None:
        return
    try:
        mode = os.stat(value).st_mode
    except (OSError, ValueError) as exc:
        code = getattr(exc, "errno", None)
        if code in (errno.ELOOP, errno.ENAMETOOLONG, errno.ENOTDIR):
            parser.error(f"argument {argument}: {value!r} {_PATH_ERRNOS[code]}; expected {expected}")
        return
    if stat.S_ISDIR(mode):
        parser.error(f"argument {argument}: {value!r} is a directory; expected {expected}")


def _same_file(a: str | os.PathLike[str], b: str | os.PathLike[str]) -> bool:
    """:func:`same_file`, False where a path cannot be resolved at all (a symlink loop: never the other file)."""
    try:
        return same_file(a, b)
    except (OSError, RuntimeError, ValueError):
        return False


def _output_path(parser: argparse.ArgumentParser, option: str, value: str | None, expected: str) -> Path | None:
    """``value`` as the path of a regular file that can be written (else a usage error naming ``option``)."""
    if value is None:
        return None
    problem = _path_error(value, expected) or check_writable_path(value, expected=expected)
    if problem is not None:
        parser.error(f"argument {option}: {problem}")
    return Path(value)


def _refuse_one_file(parser: argparse.ArgumentParser, paths: list[tuple[str, Path | None]], inputs: list[tuple[str, str]]
                     ) -> None:
    """A usage error if two outputs, or an output and an input, are one file (symlinks and hard links too)."""
    outputs = [(option, path) for option, path in paths if path is not None]
    for i, (option, path) in enumerate(outputs):
        for other, other_path in outputs[:i]:
            if _same_file(path, other_path):
                parser.error(f"argument {option}: {str(path)!r} is the same file as {other}; expected another path")
        for what, source in inputs:
            if _same_file(path, source):
                parser.error(f"argument {option}: {str(path)!r} is {what}; expected another path")


# ------------------------------------------------------------------------------ run


def _run(args: argparse.Namespace, parser: argparse.ArgumentParser) -> int:
    _input_path(parser, "SCENE", args.scene, "a scene YAML file")
    csv_path = _output_path(parser, "--csv", args.csv, "a CSV file")
    record_path = _output_path(parser, "--record", args.record, "an .mcap file")
    imu_path = _output_path(parser, "--imu-csv", args.imu_csv, "a CSV file")
    _refuse_one_file(parser, [("--csv", csv_path), ("--record", record_path), ("--imu-csv", imu_path)],
                     [("the scene file", args.scene)])
    from .offline.run import run_offline, sample_interval, steps_for

    try:
        total = steps_for(args.duration, args.dt)
    except ValueError as exc:
        parser.error(f"argument --dt: {str(exc).removeprefix('dt: ')}")
    try:
        every = sample_interval(args.rate, args.dt)
    except ValueError as exc:
        parser.error(f"argument --rate: {str(exc).removeprefix('rate: ')}")
    scene = load_scene(args.scene)
    from .core import NonFiniteStateError, Simulator

    try:
        sim = Simulator(scene, integrator=args.integrator, dt=args.dt, model_reduction=not args.no_reduction,
                        threads=args.threads)
    except ValueError as exc:
        if not str(exc).startswith("threads:"):
            raise
        parser.error(f"argument --threads: {str(exc).removeprefix('threads: ')}")
    meta = {"scene": str(Path(args.scene).resolve()), "integrator": args.integrator, "dt": repr(args.dt),
            "duration": repr(args.duration), "sample_every_steps": str(every), "version": _version(),
            "model_reduction": str(not args.no_reduction)}
    stop = args.signals.switch_to_orderly()  # from here a signal only asks the run to stop between samples
    csv_writer, recorder = _open_outputs(parser, csv_path, record_path, sim, meta, scene.text)
    outputs = [(path, writer) for path, writer in ((csv_path, csv_writer), (record_path, recorder)) if writer]
    callbacks = []
    if csv_writer is not None:
        callbacks.append(_guarded(csv_path, csv_writer.write))
    if recorder is not None:
        def record(s: Any) -> None:
            recorder.write_wrenches(s.time, s.active_scripted_wrenches())
            recorder.write_simulator(s)

        callbacks.append(_guarded(record_path, record))
    imu_writer = _open_imu_output(parser, imu_path, meta, outputs)
    if scene.imus and (imu_writer is not None or recorder is not None):
        callbacks.append(_imu_callback(scene, every * args.dt, imu_path, imu_writer, record_path, recorder))
    end = "incomplete"
    failure: _Failure | None = None
    with ExitStack() as stack:
        bar = _progress_bar(total, args.quiet)
        if bar is not None:
            stack.callback(bar.close)
        try:
            summary = run_offline(sim, args.duration, sample_every=every, on_sample=callbacks,
                                  progress=bar.update if bar is not None else None, stop=stop.is_set)
            if summary.stopped:
                raise _Interrupted(args.signals.signum)
            end = f"complete: {summary.steps} steps, t = {summary.sim_time:.9g} s"
        except NonFiniteStateError as exc:
            end = f"failed at t = {sim.time:.9g} s ({sim.step_count} steps): {exc}"
            failure = _Failure(f"{exc} (t = {sim.time:.9g} s; files written up to there are closed)")
        except _WriteError as exc:
            end = f"failed at t = {sim.time:.9g} s ({sim.step_count} steps): cannot write {exc.filename}"
            failure = _Failure(f"cannot write {exc.filename} ({exc.strerror}); the run stopped at t = {sim.time:.9g} s "
                               f"after {sim.step_count} steps; the files are closed")
        except KeyboardInterrupt as exc:
            name = signal.Signals(getattr(exc, "signum", signal.SIGINT)).name
            end = f"interrupted by {name} at t = {sim.time:.9g} s ({sim.step_count} steps)"
            raise
        finally:
            problems = _close_outputs(outputs, end)
            if problems and failure is None:
                failure = _Failure("; ".join(problems))
    if failure is not None:
        raise failure
    if not args.quiet:
        _print_summary(args, summary, csv_writer, recorder)
    return 0


def _open_outputs(parser: argparse.ArgumentParser, csv_path: Path | None, record_path: Path | None, sim: Any,
                  meta: dict[str, str], scene_text: str | None) -> tuple[Any, Any]:
    """Create the CSV writer and the recorder; a path that cannot be opened is a usage error
    (and an output already created for this run is closed and removed)."""
    from .offline.csv_io import CsvWriter
    from .offline.recording import McapRecorder

    opened: list[tuple[Path, Any]] = []
    try:
        for option, path in (("--csv", csv_path), ("--record", record_path)):
            if path is None:
                opened.append((path, None))
                continue
            try:
                writer = (CsvWriter(path, sim.body_names, meta) if option == "--csv"
                          else McapRecorder(path, metadata=meta, scene_text=scene_text))
            except OSError as exc:
                parser.error(f"argument {option}: cannot write {str(path)!r} ({exc.strerror or exc})")
            opened.append((path, writer))
            files = [w.fileno() for _, w in opened if w is not None]
            if len(files) == 2 and os.path.sameopenfile(*files):
                parser.error(f"argument {option}: {str(path)!r} is the same file as --csv; expected another path")
    except BaseException:
        for path, writer in opened:
            if writer is not None:
                try:
                    writer.close("not run: the command line was refused")
                except OSError:
                    pass
                Path(path).unlink(missing_ok=True)
        raise
    return opened[0][1], opened[1][1]


def _open_imu_output(parser: argparse.ArgumentParser, path: Path | None, meta: dict[str, str],
                     outputs: list[tuple[Path, Any]]) -> Any:
    """The ``--imu-csv`` writer (appended to ``outputs``), or None; a path that cannot be opened is a
    usage error (and the outputs already open are closed and removed)."""
    if path is None:
        return None
    from .offline.imu_csv import ImuCsvWriter

    try:
        writer = ImuCsvWriter(path, meta)
    except OSError as exc:
        for other, opened in outputs:
            try:
                opened.close("not run: the command line was refused")
            except OSError:
                pass
            Path(other).unlink(missing_ok=True)
        parser.error(f"argument --imu-csv: cannot write {str(path)!r} ({exc.strerror or exc})")
    outputs.append((path, writer))
    return writer


def _imu_callback(scene: Any, sample_dt: float, imu_path: Path | None, imu_writer: Any, record_path: Path | None,
                  recorder: Any) -> Any:
    """A sample callback writing the scene's IMUs (core/imu.py), read right after the steps before
    each sample (none at t = 0, before any step), to ``--imu-csv`` and ``--record``."""
    from .core.imu import ImuBank

    bank = ImuBank(scene.imus)

    def write(sim: Any) -> None:
        if sim.step_count == 0:
            return
        samples = bank.sample(sim, sample_dt)
        if imu_writer is not None:
            _guarded(imu_path, imu_writer.write)(samples)
        if recorder is not None:
            def record(batch: Any) -> None:
                for s in batch:
                    recorder.write_imu(s.time, s.site, s.orientation_xyzw, s.angular_velocity, s.specific_force,
                                       s.covariances)
            _guarded(record_path, record)(samples)

    return write


def _guarded(path: Path, write: Any) -> Any:
    """``write``, with an OSError (a full disk...) turned into a _WriteError naming ``path``."""
    def call(sim: Any) -> None:
        try:
            write(sim)
        except OSError as exc:
            raise _WriteError(path, exc) from None

    return call


def _close_outputs(outputs: list[tuple[Path, Any]], status: str) -> list[str]:
    """Close every output with ``status``; the problems met (each output is closed regardless)."""
    problems = []
    for path, writer in outputs:
        try:
            writer.close(status)
        except OSError as exc:
            problems.append(f"cannot finish {path} ({exc.strerror or exc})")
    return problems


def _progress_bar(total: int, quiet: bool) -> Any:
    """A tqdm bar on stderr, or None when quiet or stderr is not a terminal."""
    if quiet or not sys.stderr.isatty():
        return None
    from tqdm import tqdm

    return tqdm(total=total, unit="step", unit_scale=True, file=sys.stderr, delay=PROGRESS_DELAY_S,
                dynamic_ncols=True, leave=False, desc="simulating")


def _print_summary(args: argparse.Namespace, summary: Any, csv_writer: Any, recorder: Any) -> None:
    lines = [
        f"{args.scene}: integrator {args.integrator}, dt = {args.dt:g} s",
        f"  steps               {summary.steps} (sim time {summary.sim_time:.9g} s)",
        f"  wall time           {summary.wall_time:.3f} s",
        f"  real-time factor    {summary.real_time_factor:.3g}",
    ]
    for body in list(summary.energy_drift)[:20]:
        lines.append(
            f"  {body}: energy {summary.energy_initial[body]:.6g} J, drift max |E-E0|/|E0| = "
            f"{summary.energy_drift[body]:.3g}; |L| {summary.momentum_initial[body]:.6g} kg·m²/s, "
            f"drift max ||L|-|L0||/|L0| = {summary.momentum_drift[body]:.3g}")
    if len(summary.energy_drift) > 20:
        lines.append(f"  ... and {len(summary.energy_drift) - 20} more bodies")
    contact = summary.contact
    if contact is not None:  # energy is lost at impacts and to friction: its drift is not an error here
        lines.append(f"  contact: {contact['impacts']} impacts ({contact['events']} events), energy change at impacts "
                     f"{contact['impact_energy']:.6g} J, lowest gap {contact['lowest_gap']:.3g} m, "
                     f"{contact['resting']} bodies resting at the end")
    if csv_writer is not None:
        lines.append(f"  wrote {csv_writer.path} ({csv_writer.rows} samples)")
    if recorder is not None:
        lines.append(f"  wrote {recorder.path} ({recorder.message_count} messages)")
    if getattr(args, "imu_csv", None):
        lines.append(f"  wrote {args.imu_csv} (IMU samples)")
    print("\n".join(lines))


def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("rigid_body_sim")
    except PackageNotFoundError:
        return "unknown"


# ------------------------------------------------------------------------------ plot


def _plot(args: argparse.Namespace, parser: argparse.ArgumentParser) -> int:
    _input_path(parser, "RUN", args.run, "a CSV file or an MCAP recording")
    _input_path(parser, "--scene", args.scene, "a scene YAML file")
    run_path = Path(args.run)
    try:
        with open_for_reading(run_path, expected="a CSV file or an MCAP recording") as f:
            head = f.read(len(_MCAP_MAGIC))
    except OSError as exc:
        raise _Failure(f"{run_path}: cannot read the run ({exc.strerror or exc})") from None
    if args.output is not None:
        out = _output_path(parser, "--output", args.output, "a PNG file")
        assert out is not None
    else:
        out = run_path.with_suffix(".png")
        problem = _path_error(str(out), "a PNG file")
        if problem is not None:
            parser.error(f"argument --output: the default {problem}; pass --output")
    _refuse_one_file(parser, [("--output", out)], [("the run file itself", args.run)])

    from .offline.rundata import with_derived_quantities

    scene_text = None
    try:
        if head and _MCAP_MAGIC.startswith(head):  # an MCAP file, or one cut inside its magic
            from .offline.recording import read_recording

            data, scene_text = read_recording(run_path)
        else:
            from .offline.csv_io import read_csv

            data = read_csv(run_path)
    except (ValueError, OSError, UnicodeDecodeError) as exc:
        raise _Failure(str(exc)) from None
    status = data.meta.get("status", "")
    if status and not status.startswith("complete"):
        print(f"{PROG} plot: warning: {run_path}: the run did not end normally ({status})", file=sys.stderr)

    scene = _plot_scene(args, data, scene_text)
    if scene is not None:
        missing = [b for b in data.bodies if b not in scene.body_names]
        if missing:
            print(f"{PROG} plot: warning: the scene {scene.source} has no body {missing}; "
                  "no closed form or energy for them", file=sys.stderr)
        if any(track.energy is None for track in data.bodies.values()):
            data = with_derived_quantities(data, scene)

    bodies = list(data.bodies)
    if args.body is not None:
        if args.body not in data.bodies:
            raise _Failure(f"{run_path}: no body {args.body!r}; the run has {bodies}")
        bodies = [args.body]
    from .offline.plotting import plot_body

    targets = [out if len(bodies) == 1 else out.with_name(f"{out.stem}_{body}{out.suffix or '.png'}") for body in bodies]
    for target in targets:
        problem = _path_error(str(target), "a PNG file") or check_writable_path(target, expected="a PNG file")
        if problem is not None or _same_file(target, run_path):
            raise _Failure(f"cannot write {target}: {problem or 'it is the run file itself'}")
    for body, target in zip(bodies, targets):
        try:
            plot_body(data, body, target, scene=scene)
        except OSError as exc:
            raise _Failure(f"cannot write {target} ({exc.strerror or exc})") from None
        print(f"wrote {target}")
    return 0


def _plot_scene(args: argparse.Namespace, data: Any, scene_text: str | None) -> Scene | None:
    """The run's scene: --scene (its errors are fatal), else the attached or named one (warn on failure)."""
    if args.scene is not None:
        return load_scene(args.scene)
    from .core.scene import load_scene_text

    try:
        if scene_text is not None:
            return load_scene_text(scene_text, f"{args.run} (its attached scene.yaml)")
        named = data.meta.get("scene")
        if named and Path(named).is_file():
            return load_scene(named)
    except SceneError as exc:
        print(f"{PROG} plot: warning: the run's scene cannot be loaded ({exc}); plotting without it",
              file=sys.stderr)
        return None
    print(f"{PROG} plot: warning: the run names no readable scene; pass --scene for energy and the closed form",
          file=sys.stderr)
    return None


# ------------------------------------------------------------------------------ describe, check


def _describe(args: argparse.Namespace, parser: argparse.ArgumentParser) -> int:
    from .core import describe_scene

    _input_path(parser, "SCENE", args.scene, "a scene YAML file")
    scene = load_scene(args.scene)
    bodies = describe_scene(scene, model_reduction=not args.no_reduction)
    if args.json:
        print(json.dumps({"scene": scene.source, "gravity": _floats(scene.model.gravity_W), "bodies": bodies}, indent=2))
        return 0
    gravity = scene.model.gravity_W
    lines = [f"scene {scene.source}: {len(bodies)} bod{'y' if len(bodies) == 1 else 'ies'}, "
             f"gravity {_vec(gravity) + ' m/s²' if scene.model.has_gravity else 'none'}, "
             f"{len(scene.wrenches)} scripted wrench{'' if len(scene.wrenches) == 1 else 'es'}"]
    for d in bodies:
        lines += [
            "",
            f"{d['name']}: {d['model']} model (motion: {d['motion']})",
            f"  why                {d['model_reason']}",
            f"  mass               {d['mass']:.6g} kg",
            f"  principal moments  {_vec(d['principal_moments'])} kg·m² (about the centre of mass)",
            "  principal axes     " + ", ".join(f"e{k + 1} = {_vec(a)}" for k, a in enumerate(d["principal_axes_B"]))
            + " (in body axes)",
            "  inertia tensor     " + ", ".join(_vec(row) for row in d["inertia_B"]) + " kg·m² (body axes)",
            f"  initial pose       position {_vec(d['position_world'])} m, orientation xyzw {_vec(d['orientation_xyzw'])}",
            f"  initial twist      linear {_vec(d['linear_velocity_world'])} m/s, angular {_vec(d['angular_velocity_world'])} "
            f"rad/s (world axes) = {_vec(d['angular_velocity_body'])} rad/s (body axes)",
            f"  initial energy     {d['kinetic_energy']:.6g} J kinetic, |L| = {d['angular_momentum_norm']:.6g} kg·m²/s",
            f"  damping            linear {d['damping']['linear']:g} N·s/m, angular {d['damping']['angular']:g} N·m·s/rad",
        ]
        if d["sites"]:
            lines.append("  sites              " + "; ".join(
                f"{s['name']} at {_vec(s['position_B'])} m ({s['axes']} axes{', IMU' if s.get('imu') else ''})"
                for s in d["sites"]))
        else:
            lines.append("  sites              none")
        lines.append("  wrench frames      " + ", ".join(d["frames"]))
        for w in d["scripted_wrenches"]:
            until = "on" if w["duration"] is None else f"{w['start'] + w['duration']:g}"
            lines.append(f"  scripted wrench    in {w['frame']}: force {_vec(w['force'])} N, torque {_vec(w['torque'])} N·m, "
                         f"t in [{w['start']:g}, {until}) s")
    print("\n".join(lines))
    return 0


def _check(args: argparse.Namespace, parser: argparse.ArgumentParser) -> int:
    _input_path(parser, "SCENE", args.scene, "a scene YAML file")
    scene = load_scene(args.scene)
    count = len(scene.body_names)
    print(f"{scene.source}: ok ({count} bod{'y' if count == 1 else 'ies'}: {', '.join(scene.body_names)}; "
          f"{len(scene.wrenches)} scripted wrench{'' if len(scene.wrenches) == 1 else 'es'})")
    return 0


def _shard(args: argparse.Namespace, parser: argparse.ArgumentParser) -> int:
    from .tools.shards import MANIFEST, write_shards

    _input_path(parser, "SCENE", args.scene, "a scene YAML file")
    try:
        specs = write_shards(args.scene, args.shards, args.out)
    except ValueError as exc:
        if isinstance(exc, SceneError):
            raise
        parser.error(str(exc))
    out = Path(args.out)
    for spec in specs:
        print(f"{spec.file}: {spec.bodies} bodies from {spec.first_body!r}, namespace {spec.namespace}")
    print(f"{out / MANIFEST}: the shards and the command that runs each")
    return 0


def _floats(values: Any) -> list[float]:
    return [float(v) for v in values]


def _vec(values: Any) -> str:
    return "[" + ", ".join(f"{float(v):.6g}" for v in values) + "]"


if __name__ == "__main__":
    sys.exit(main())
