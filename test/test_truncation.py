"""Recordings cut anywhere read up to the cut: never a traceback, always reported as cut short.

A recording is cut when its writer dies (SIGKILL, a crash), the disk fills up, or a copy stops
half way: the file then ends at an arbitrary byte. Here a recording written by ``rigid-body-sim
run --record`` (chunks of 256 KiB before compression) and one written by the node process (a
chunk flushed every 0.5 s) are each cut at the edges (inside the magic, the header, right after
it, the last byte), on both sides of every chunk's end (the chunk whole, one byte short) and at
200 random byte offsets (in the default run 5 for the CLI's, 20 for the node's). Each cut file
must either read, with a status starting ``cut short``, exactly the samples that lie in the
chunks written whole before the cut (worked out from the complete file's chunk index, with
mcap's own reader) with the complete file's values, or, when no whole sample lies before the
cut, be refused with a ValueError that says ``cut short``. ``rigid-body-sim plot`` on cut files
(the CLI's; it reads them with the same reader) exits 0 or 1 with a one-line message, never a
traceback.
"""

from __future__ import annotations

import contextlib
import io
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import yaml

from rigid_body_sim.cli import main
from rigid_body_sim.offline.recording import CUT_SHORT, read_recording

CUTS = 200
SCENE = {
    "bodies": {
        "box": {"mass": 2.0, "inertia": {"box": [1.0, 0.6, 0.4]}, "pose": {"position": [0.0, 0.0, 1.0]},
                "twist": {"angular": [0.2, 0.1, 0.5]}, "sites": {"corner": {"position": [0.5, 0.3, 0.0]}}},
        "ball": {"mass": 1.0, "inertia": {"sphere": 0.1}, "twist": {"linear": [1.0, 0.0, 0.0]}},
        "rod": {"mass": 0.5, "inertia": {"box": [0.05, 0.05, 2.0]}, "twist": {"angular": [1.0, 0.0, 0.2]}},
    },
    "wrenches": [{"body": "box", "frame": "box/corner", "force": [0.0, 10.0, 0.0], "start": 0.5, "duration": 1.0}],
}


def chunk_samples(path: Path) -> list[tuple[int, dict[str, set[int]], dict[str, set[int]]]]:
    """Per chunk of a complete recording, in file order: (end offset, pose log times by body, twist
    log times by body), from its chunk index and the chunk's own records (mcap's reader)."""
    from mcap.reader import make_reader
    from mcap.records import Chunk, Message
    from mcap.stream_reader import StreamReader, breakup_chunk

    with open(path, "rb") as f:
        summary = make_reader(f).get_summary()
        assert summary is not None and summary.chunk_indexes
        topics = {channel.id: channel.topic for channel in summary.channels.values()}
        out = []
        for index in sorted(summary.chunk_indexes, key=lambda c: c.chunk_start_offset):
            f.seek(index.chunk_start_offset)
            chunk = next(iter(StreamReader(f, skip_magic=True, emit_chunks=True).records))
            assert isinstance(chunk, Chunk)
            poses: dict[str, set[int]] = {}
            twists: dict[str, set[int]] = {}
            for record in breakup_chunk(chunk):
                if isinstance(record, Message):
                    topic = topics[record.channel_id]
                    kind, body = topic.rsplit("/", 1)[-1], topic.strip("/").split("/")[0]
                    if kind in ("pose", "twist"):
                        (poses if kind == "pose" else twists).setdefault(body, set()).add(record.log_time)
            out.append((index.chunk_start_offset + index.chunk_length, poses, twists))
    return out


def whole_chunks(path: Path) -> int:
    """How many whole chunk records a recording being written holds so far (mcap's stream reader,
    up to the first record not yet whole)."""
    from mcap.records import Chunk
    from mcap.stream_reader import StreamReader

    count = 0
    with open(path, "rb") as f:
        try:
            for record in StreamReader(f, emit_chunks=True).records:
                count += isinstance(record, Chunk)
        except Exception:  # noqa: BLE001 - the record being written: the count so far
            pass
    return count


def expected_times(chunks: list[tuple[int, dict[str, set[int]], dict[str, set[int]]]], cut: int) -> list[int]:
    """The sample times read_recording must return for a cut at byte ``cut``: those at which every
    body seen with both a pose and a twist has both, in chunks that end at or before the cut."""
    poses: dict[str, set[int]] = {}
    twists: dict[str, set[int]] = {}
    for end, chunk_poses, chunk_twists in chunks:
        if end > cut:
            break
        for body, times in chunk_poses.items():
            poses.setdefault(body, set()).update(times)
        for body, times in chunk_twists.items():
            twists.setdefault(body, set()).update(times)
    bodies = [b for b in poses if b in twists]
    if not bodies:
        return []
    return sorted(set.intersection(*(poses[b] & twists[b] for b in bodies)))


def cut_offsets(size: int, seed: int, cuts: int, chunk_ends: list[int]) -> list[int]:
    """The edges of the file, both sides of each chunk's end, and ``cuts`` random offsets."""
    rng = np.random.default_rng(seed)
    edges = [0, 1, 5, 7, 8, 9, 30, 100, size - 1]
    boundaries = [cut for end in chunk_ends for cut in (end - 1, end)]
    return edges + boundaries + sorted(int(c) for c in rng.integers(0, size, cuts))


def check_cuts(tmp_path: Path, full: Path, seed: int, cuts: int = CUTS) -> dict[str, int]:
    """Cut ``full`` at ``cuts`` random offsets (and the edges, and both sides of each chunk's end); every
    cut reads as required. Returns counts (``chunks``: the chunks of the complete file)."""
    data = full.read_bytes()
    whole, whole_scene = read_recording(full)
    assert whole.meta["status"].startswith("complete") and whole_scene
    index = {round(t * 1e9): k for k, t in enumerate(whole.time)}
    chunks = chunk_samples(full)
    assert len(chunks) >= 3, "the recording should span several chunks"
    counts = {"read": 0, "refused": 0, "cuts": 0, "chunks": len(chunks)}
    cut_file = tmp_path / "cut.mcap"
    for cut in cut_offsets(len(data), seed, cuts, [end for end, _poses, _twists in chunks]):
        cut_file.write_bytes(data[:cut])
        expected = expected_times(chunks, cut)
        counts["cuts"] += 1
        if not expected:
            with pytest.raises(ValueError, match=CUT_SHORT):
                read_recording(cut_file)
            counts["refused"] += 1
            continue
        run, scene = read_recording(cut_file)
        assert run.meta["status"].startswith(f"{CUT_SHORT}: "), (cut, run.meta.get("status"))
        assert scene == whole_scene, cut  # the scene is attached before the first sample
        times = [round(t * 1e9) for t in run.time]
        assert times == expected, cut
        rows = [index[t] for t in times]
        assert set(run.bodies) == set(whole.bodies)
        for body, track in run.bodies.items():
            full_track = whole.bodies[body]
            assert track.position_world.tolist() == full_track.position_world[rows].tolist()
            assert track.orientation_xyzw.tolist() == full_track.orientation_xyzw[rows].tolist()
            assert track.linear_velocity_world.tolist() == full_track.linear_velocity_world[rows].tolist()
            assert track.angular_velocity_world.tolist() == full_track.angular_velocity_world[rows].tolist()
        counts["read"] += 1
    assert counts["read"] >= cuts // 2  # most cuts leave whole chunks before them
    return counts


def check_plot_on_cuts(tmp_path: Path, full: Path, seed: int, n: int = 3) -> None:
    """``rigid-body-sim plot`` on cut files: exit 0 (with the cut-short warning) or 1, one line, no traceback."""
    data = full.read_bytes()
    rng = np.random.default_rng(seed)
    for k, cut in enumerate([1, 3, 5, *sorted(int(c) for c in rng.integers(0, len(data), n))]):
        cut_file = tmp_path / f"plot_cut_{k}.mcap"
        cut_file.write_bytes(data[:cut])
        stderr = io.StringIO()
        with contextlib.redirect_stderr(stderr), contextlib.redirect_stdout(io.StringIO()):
            code = main(["plot", str(cut_file), "--body", "box", "-o", str(tmp_path / f"plot_cut_{k}.png")])
        text = stderr.getvalue()
        assert "Traceback" not in text
        if code == 0:
            assert f"did not end normally ({CUT_SHORT}" in text
            assert (tmp_path / f"plot_cut_{k}.png").stat().st_size > 0
        else:
            assert code == 1
            lines = [line for line in text.splitlines() if not line.startswith("rigid-body-sim plot: warning")]
            assert len(lines) == 1 and str(cut_file) in lines[0] and CUT_SHORT in lines[0], text


@pytest.mark.timeout(300)
@pytest.mark.parametrize("cuts", [pytest.param(5, id="5 cuts"), pytest.param(CUTS, id="200 cuts", marks=pytest.mark.slow)])
def test_cli_recording_cut_anywhere_reads_up_to_the_cut(tmp_path: Path, cuts: int) -> None:
    """The CLI's recording cut at the edges, both sides of each chunk's end and random
    offsets (5 in the default run, 200 in the slow one); ``rigid-body-sim plot`` on cut files."""
    scene = tmp_path / "scene.yaml"
    scene.write_text(yaml.safe_dump(SCENE), encoding="utf-8")
    full = tmp_path / "run.mcap"
    assert main(["run", str(scene), "--duration", "8", "--dt", "0.01", "--record", str(full), "--quiet"]) == 0
    counts = check_cuts(tmp_path, full, seed=1, cuts=cuts)
    assert counts["cuts"] == cuts + 9 + 2 * counts["chunks"]
    check_plot_on_cuts(tmp_path, full, seed=2, n=1 if cuts < CUTS else 6)  # a plot costs ~1 CPU-s


@pytest.mark.ros
@pytest.mark.timeout(300)
@pytest.mark.parametrize("cuts", [pytest.param(20, id="20 cuts"), pytest.param(CUTS, id="200 cuts", marks=pytest.mark.slow)])
def test_node_recording_cut_anywhere_reads_up_to_the_cut(tmp_path: Path, cuts: int) -> None:
    """The node flushes a chunk every 0.5 s of wall time: running until five chunks are on disk gives
    several chunks, cut at the edges, both sides of each chunk's end and random offsets (20 in the
    default run, 200 in the slow one). (``rigid-body-sim plot`` of cut files: the CLI's test.)"""
    scene = tmp_path / "scene.yaml"
    scene.write_text(yaml.safe_dump(SCENE), encoding="utf-8")
    full = tmp_path / "node.mcap"
    log_path = tmp_path / "node.log"
    with open(log_path, "w") as log:
        process = subprocess.Popen(
            [sys.executable, "-m", "rigid_body_sim.ros.main", "--ros-args", "-p", f"scene:={scene}",
             "-p", f"record_path:={full}", "-p", "status_period:=0.0", "-p", "diagnostics_period:=0.0"],
            stdout=log, stderr=subprocess.STDOUT, env=os.environ.copy())
    try:
        deadline = time.monotonic() + 60.0
        while not (full.exists() and "recording to" in log_path.read_text()):
            assert process.poll() is None, log_path.read_text()
            assert time.monotonic() < deadline, log_path.read_text()
            time.sleep(0.05)
        # Several chunks: until five whole chunks are on disk (one flushed every 0.5 s of wall time), not a fixed
        # 3 s; the stop may write one more.
        while whole_chunks(full) < 5:
            assert process.poll() is None, log_path.read_text()
            assert time.monotonic() < deadline + 60.0, log_path.read_text()
            time.sleep(0.05)
        process.send_signal(signal.SIGINT)
        assert process.wait(timeout=30) == 0, log_path.read_text()
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()
    counts = check_cuts(tmp_path, full, seed=3, cuts=cuts)
    assert counts["cuts"] == cuts + 9 + 2 * counts["chunks"]


_FULL_DISK = """\
import resource, signal, sys
signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # a write past the limit fails with EFBIG, as on a full disk
limit = int(sys.argv.pop(1))
resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))
from rigid_body_sim.cli import main
sys.exit(main(sys.argv[1:]))
"""


# in the header, inside the first 256 KiB chunk, after it; the other two sizes in test-slow
@pytest.mark.parametrize("limit", [3_000, pytest.param(40_000, marks=pytest.mark.slow), 90_000,
                                   pytest.param(150_000, marks=pytest.mark.slow), 260_000])
def test_recordings_of_a_full_disk_read_up_to_where_the_disk_filled(tmp_path: Path, limit: int) -> None:
    """``run --record`` with the file size capped (a write fails with EFBIG, as on a full disk):
    the run says it could not write, and the recording it left reads up to the cut, as cut short."""
    scene = tmp_path / "scene.yaml"
    scene.write_text(yaml.safe_dump(SCENE), encoding="utf-8")
    record = tmp_path / "full.mcap"
    done = subprocess.run([sys.executable, "-c", _FULL_DISK, str(limit), "run", str(scene), "-T", "8",
                           "--record", str(record), "-q"], capture_output=True, text=True, timeout=120, check=False)
    assert done.returncode == 1 and "Traceback" not in done.stderr, done.stderr
    assert "cannot write" in done.stderr or "cannot finish" in done.stderr, done.stderr
    assert 0 < record.stat().st_size <= limit
    try:
        run, _scene = read_recording(record)
    except ValueError as exc:
        assert CUT_SHORT in str(exc)
    else:
        assert run.meta["status"].startswith(f"{CUT_SHORT}: ")
        assert len(run.time) > 0 and np.all(np.diff(run.time) > 0)
    # ``rigid-body-sim plot`` of a cut file, read by the same reader: test_cli_recording_cut_anywhere_reads_up_to_the_cut.
