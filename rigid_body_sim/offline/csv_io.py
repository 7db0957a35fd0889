"""CSV files of a run: one row per sample, written by ``rigid-body-sim run --csv`` and read by ``plot``.

Layout: a few comment lines starting with ``#`` (``# key: value``: the scene, integrator, dt
and this column list), then a header row, then one row per sample. Numbers are written with
``repr`` (the shortest text that reads back to the same float64). Columns, SI units:

===========================  =====================================================================
column                       meaning
===========================  =====================================================================
``t``                        sim time, s
``B.px B.py B.pz``           centre of mass of body B, m, world frame
``B.qx B.qy B.qz B.qw``      orientation of B's body frame in the world (B → W), quaternion x y z w
``B.vx B.vy B.vz``           centre-of-mass velocity, m/s, world axes
``B.wx B.wy B.wz``           angular velocity, rad/s, world axes
``B.wbx B.wby B.wbz``        angular velocity, rad/s, B's body axes
``B.energy``                 kinetic + gravitational potential energy, J (potential zero at the origin)
``B.L``                      |angular momentum| about the centre of mass, kg·m²/s
===========================  =====================================================================

How the run ended is its last ``# status:`` line: ``# status: incomplete: ...`` comes first,
and the writer ends the file with ``# status: complete: N steps, t = T s``, ``# status:
interrupted by SIGTERM at t = T s (N steps)`` (Ctrl-C or SIGTERM) or ``# status: failed: ...``
(a blow-up). A file whose last status is still ``incomplete`` was cut off: its writer was
killed; its last row may be cut in half (:func:`read_csv` drops it and says so in ``status``).

Other readers: ``pandas.read_csv(path, comment="#")``; with the standard library,
``csv.DictReader(line for line in open(path) if not line.startswith("#"))``; with numpy,
``numpy.genfromtxt((line for line in open(path) if not line.startswith("#")), delimiter=",",
names=True, deletechars="")`` (genfromtxt would take a leading comment line for the names).
"""

from __future__ import annotations

import csv
import os
from pathlib import Path
from typing import IO, Any, Mapping

import numpy as np

from ..core import Simulator
from ..safe_open import open_for_reading, open_for_writing, text_writer
from .rundata import MAX_RUN_FILE_BYTES, BodyTrack, RunData

__all__ = ["CsvWriter", "read_csv", "COLUMNS", "column_names", "STATUS_INCOMPLETE", "MAX_LINE_BYTES"]

#: The status a file has until its writer closes it.
STATUS_INCOMPLETE = "incomplete: the run was never finished (its writer was killed or crashed)"
#: Longest line :func:`read_csv` reads, bytes (a row of 10⁵ bodies is about 45 MB).
MAX_LINE_BYTES = 64 << 20

#: Per-body columns, in order; the CSV header names them ``<body>.<column>``.
COLUMNS = ("px", "py", "pz", "qx", "qy", "qz", "qw", "vx", "vy", "vz", "wx", "wy", "wz",
           "wbx", "wby", "wbz", "energy", "L")
_COLUMN_TEXT = ("t [s]; per body B: B.px B.py B.pz [m, world]; B.qx B.qy B.qz B.qw [orientation B -> world]; "
                "B.vx B.vy B.vz [m/s, world axes]; B.wx B.wy B.wz [rad/s, world axes]; "
                "B.wbx B.wby B.wbz [rad/s, body axes]; B.energy [J, kinetic + potential]; B.L [kg m^2/s, |L| about the COM]")


def column_names(bodies: tuple[str, ...] | list[str]) -> list[str]:
    """The header row for ``bodies``: ``t`` then ``<body>.<column>`` for each of :data:`COLUMNS`."""
    return ["t"] + [f"{body}.{column}" for body in bodies for column in COLUMNS]


class CommentedCsvFile:
    """A CSV file that starts with ``# title`` and ``# key: value`` lines (``status`` first
    ``incomplete``) and ends with ``# status: <how the run ended>``: what CsvWriter and
    imu_csv.ImuCsvWriter share. Subclasses write their header row and rows through ``self._csv``.

    Raises
    ------
    OSError
        If the file cannot be created; :class:`rigid_body_sim.safe_open.NotRegularFileError` for a
        FIFO, device or directory (never blocking, nothing written to it).
    """

    def __init__(self, path: str | os.PathLike[str], title: str, meta: Mapping[str, str] | None = None):
        self.path = Path(path)
        self._file: IO[str] | None = text_writer(open_for_writing(self.path, expected="a CSV file"))
        self._file.write(f"# {title}\n")
        for key, value in {**(meta or {}), "status": STATUS_INCOMPLETE}.items():
            self._file.write(f"# {_one_line(key)}: {_one_line(value)}\n")
        self._csv = csv.writer(self._file)
        self.rows = 0

    def fileno(self) -> int:
        """The open file's descriptor (e.g. to compare two outputs with ``os.path.sameopenfile``)."""
        if self._file is None:
            raise ValueError(f"CSV file {self.path} is closed")
        return self._file.fileno()

    def close(self, status: str = "complete") -> None:
        """End the file with ``# status: <status>`` (how the run ended), flush and close it. Safe to
        call twice.

        Raises
        ------
        OSError
            If the end cannot be written (a full disk); the file is closed all the same.
        """
        if self._file is None:
            return
        file, self._file = self._file, None
        try:
            file.write(f"# status: {_one_line(status)}\n")
            file.flush()
        finally:
            try:
                file.close()
            except OSError:  # the write above already failed: report that one
                pass

    def __enter__(self):
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()


class CsvWriter(CommentedCsvFile):
    """Writes the samples of a simulation to a CSV file (see the module docstring for the columns).

    Parameters
    ----------
    path : str or Path
    bodies : sequence of str
        The bodies to write, in column order.
    meta : mapping of str to str, optional
        Written as ``# key: value`` lines above the header (newlines in them become spaces).

    Raises
    ------
    OSError
        If the file cannot be created; :class:`rigid_body_sim.safe_open.NotRegularFileError` for a
        FIFO, device or directory (never blocking, nothing written to it).
    """

    def __init__(self, path: str | os.PathLike[str], bodies: tuple[str, ...] | list[str],
                 meta: Mapping[str, str] | None = None):
        super().__init__(path, "rigid_body_sim run: one row per sample, SI units", meta)
        self.bodies = tuple(bodies)
        self._file.write(f"# columns: {_COLUMN_TEXT}\n")
        self._csv.writerow(column_names(self.bodies))

    def write(self, sim: Simulator) -> None:
        """Append one row: ``sim``'s state at ``sim.time``."""
        if self._file is None:
            raise ValueError(f"CSV file {self.path} is closed")
        index = [sim.body_names.index(b) for b in self.bodies]
        columns = np.concatenate([
            sim.positions_world()[index], sim.orientations_xyzw()[index], sim.linear_velocities_world()[index],
            sim.angular_velocities_world()[index], sim.angular_velocities_body()[index],
            (sim.kinetic_energy() + sim.potential_energy())[index, None],
            np.linalg.norm(sim.angular_momentum(), axis=1)[index, None],
        ], axis=1)
        self._csv.writerow([repr(float(sim.time))] + [repr(float(x)) for x in columns.ravel()])
        self.rows += 1

def _one_line(value: Any) -> str:
    return " ".join(str(value).split())


def read_csv(path: str | os.PathLike[str]) -> RunData:
    """Read a CSV file written by :class:`CsvWriter`.

    Only a regular file of at most :data:`~rigid_body_sim.offline.rundata.MAX_RUN_FILE_BYTES`
    is read, line by line, no line longer than :data:`MAX_LINE_BYTES`. A last row cut short
    (the writer was killed) is dropped, and ``meta["status"]`` says so.

    Raises
    ------
    ValueError
        If the file is not such a CSV file (the message says what is missing or malformed).
    """
    path = Path(path)
    meta: dict[str, str] = {}
    try:
        handle = open_for_reading(path, expected="a CSV file from 'rigid-body-sim run --csv'")
    except OSError as exc:
        raise ValueError(f"{path}: cannot read the run ({exc.strerror or exc})") from None
    header: list[str] | None = None
    rows: list[np.ndarray] = []
    cut = False
    with handle:
        size = os.fstat(handle.fileno()).st_size
        if size > MAX_RUN_FILE_BYTES:
            raise ValueError(f"{path}: the run is {size} bytes; expected at most {MAX_RUN_FILE_BYTES}")
        number = 0
        while True:
            raw = handle.readline(MAX_LINE_BYTES + 1)
            if not raw:
                break
            if len(raw) > MAX_LINE_BYTES:
                raise ValueError(f"{path}: expected lines of at most {MAX_LINE_BYTES} bytes, got a longer one")
            try:
                line = raw.decode("utf-8")
            except UnicodeDecodeError as exc:
                raise ValueError(f"{path}: expected UTF-8 text ({exc.reason} at byte {exc.start} of a line)") from None
            if line.startswith("#"):
                key, sep, value = line[1:].partition(":")
                if sep:
                    meta[key.strip()] = value.strip()
                continue
            if not line.strip():
                continue
            if not raw.endswith(b"\n"):  # the writer ends every line: this one was cut by a killed writer
                cut = True
                break
            fields = next(csv.reader([line]))
            if header is None:
                header = _check_header(path, fields)
                continue
            number += 1
            if len(fields) != len(header):
                raise ValueError(f"{path}: expected {len(header)} values in sample row {number}, got {len(fields)}")
            try:
                rows.append(np.array([float(x) for x in fields]))
            except ValueError as exc:
                raise ValueError(f"{path}: expected numbers in every sample row ({exc})") from None
    if header is None:
        raise ValueError(f"{path}: expected a header row and at least one sample row, found none")
    if not rows:
        raise ValueError(f"{path}: expected at least one sample row after the header")
    if cut:
        meta["status"] = f"cut short: the last row was incomplete and is left out ({meta.get('status', 'no status')})"
    table = np.array(rows)
    bodies = list(dict.fromkeys(name.rpartition(".")[0] for name in header[1:]))
    tracks = {}
    n = len(COLUMNS)
    for i, body in enumerate(bodies):
        block = table[:, 1 + i * n: 1 + (i + 1) * n]
        tracks[body] = BodyTrack(
            position_world=block[:, 0:3], orientation_xyzw=block[:, 3:7], linear_velocity_world=block[:, 7:10],
            angular_velocity_world=block[:, 10:13], angular_velocity_body=block[:, 13:16],
            energy=block[:, 16], angular_momentum_norm=block[:, 17])
    return RunData(time=table[:, 0], bodies=tracks, meta=meta, source=str(path))


def _check_header(path: Path, header: list[str]) -> list[str]:
    if not header or header[0] != "t":
        raise ValueError(f"{path}: expected the first column to be 't', got {header[:1]}")
    bodies: list[str] = []
    for name in header[1:]:
        body, _, column = name.rpartition(".")
        if column not in COLUMNS or not body:
            raise ValueError(f"{path}: expected columns named <body>.<one of {list(COLUMNS)}>, got {name[:100]!r}")
        if body not in bodies:
            bodies.append(body)
    if header != column_names(bodies):
        raise ValueError(f"{path}: expected the columns {column_names(bodies)[:40]}, got {header[:40]}")
    return header
