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
from .rundata import BodyTrack, RunData

__all__ = ["CsvWriter", "read_csv", "COLUMNS", "column_names"]

#: Per-body columns, in order; the CSV header names them ``<body>.<column>``.
COLUMNS = ("px", "py", "pz", "qx", "qy", "qz", "qw", "vx", "vy", "vz", "wx", "wy", "wz",
           "wbx", "wby", "wbz", "energy", "L")
_COLUMN_TEXT = ("t [s]; per body B: B.px B.py B.pz [m, world]; B.qx B.qy B.qz B.qw [orientation B -> world]; "
                "B.vx B.vy B.vz [m/s, world axes]; B.wx B.wy B.wz [rad/s, world axes]; "
                "B.wbx B.wby B.wbz [rad/s, body axes]; B.energy [J, kinetic + potential]; B.L [kg m^2/s, |L| about the COM]")


def column_names(bodies: tuple[str, ...] | list[str]) -> list[str]:
    """The header row for ``bodies``: ``t`` then ``<body>.<column>`` for each of :data:`COLUMNS`."""
    return ["t"] + [f"{body}.{column}" for body in bodies for column in COLUMNS]


class CsvWriter:
    """Writes the samples of a simulation to a CSV file (see the module docstring for the columns).

    Parameters
    ----------
    path : str or Path
    bodies : sequence of str
        The bodies to write, in column order.
    meta : mapping of str to str, optional
        Written as ``# key: value`` lines above the header (no newlines in keys or values).
    """

    def __init__(self, path: str | os.PathLike[str], bodies: tuple[str, ...] | list[str],
                 meta: Mapping[str, str] | None = None):
        self.path = Path(path)
        self.bodies = tuple(bodies)
        self._file: IO[str] | None = open(self.path, "w", newline="", encoding="utf-8")  # noqa: SIM115
        self._file.write("# rigid_body_sim run: one row per sample, SI units\n")
        for key, value in (meta or {}).items():
            self._file.write(f"# {key}: {value}\n")
        self._file.write(f"# columns: {_COLUMN_TEXT}\n")
        self._csv = csv.writer(self._file)
        self._csv.writerow(column_names(self.bodies))
        self.rows = 0

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

    def close(self) -> None:
        """Flush and close the file. Safe to call twice."""
        if self._file is not None:
            self._file.close()
            self._file = None

    def __enter__(self) -> "CsvWriter":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()


def read_csv(path: str | os.PathLike[str]) -> RunData:
    """Read a CSV file written by :class:`CsvWriter`.

    Raises
    ------
    ValueError
        If the file is not such a CSV file (the message says what is missing or malformed).
    """
    path = Path(path)
    meta: dict[str, str] = {}
    with open(path, newline="", encoding="utf-8") as f:
        lines = [line for line in f]
    body_lines = []
    for line in lines:
        if line.startswith("#"):
            key, sep, value = line[1:].partition(":")
            if sep:
                meta[key.strip()] = value.strip()
        elif line.strip():
            body_lines.append(line)
    if not body_lines:
        raise ValueError(f"{path}: expected a header row and at least one sample row, found none")
    rows = list(csv.reader(body_lines))
    header, rows = rows[0], rows[1:]
    if not header or header[0] != "t":
        raise ValueError(f"{path}: expected the first column to be 't', got {header[:1]}")
    bodies: list[str] = []
    for name in header[1:]:
        body, _, column = name.rpartition(".")
        if column not in COLUMNS or not body:
            raise ValueError(f"{path}: expected columns named <body>.<one of {list(COLUMNS)}>, got {name!r}")
        if body not in bodies:
            bodies.append(body)
    if header != column_names(bodies):
        raise ValueError(f"{path}: expected the columns {column_names(bodies)}, got {header}")
    if not rows:
        raise ValueError(f"{path}: expected at least one sample row after the header")
    for number, row in enumerate(rows, start=1):
        if len(row) != len(header):
            raise ValueError(f"{path}: expected {len(header)} values in sample row {number}, got {len(row)}")
    try:
        table = np.array([[float(x) for x in row] for row in rows])
    except ValueError as exc:
        raise ValueError(f"{path}: expected numbers in every sample row ({exc})") from None
    tracks = {}
    n = len(COLUMNS)
    for i, body in enumerate(bodies):
        block = table[:, 1 + i * n: 1 + (i + 1) * n]
        tracks[body] = BodyTrack(
            position_world=block[:, 0:3], orientation_xyzw=block[:, 3:7], linear_velocity_world=block[:, 7:10],
            angular_velocity_world=block[:, 10:13], angular_velocity_body=block[:, 13:16],
            energy=block[:, 16], angular_momentum_norm=block[:, 17])
    return RunData(time=table[:, 0], bodies=tracks, meta=meta, source=str(path))
