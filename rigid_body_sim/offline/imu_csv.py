"""CSV files of IMU samples, written by ``rigid-body-sim run --imu-csv``: one row per sample of one IMU.

Columns (SI units; a site's IMU as the node publishes it on ``<body>/<site>/imu``, core/imu.py):

==================  ==========================================================================
column              meaning
==================  ==========================================================================
``t``               sim time, s
``site``            ``<body>/<site>`` (the sensor frame)
``ax ay az``        specific force (acceleration minus gravity, REP-145), m/s², sensor axes
``gx gy gz``        angular velocity, rad/s, sensor axes
``qx qy qz qw``     orientation of the sensor frame in the world (empty when ``orientation: false``)
==================  ==========================================================================

Comment lines start with ``#``; the last one, ``# status: ...``, says how the run ended, as in
:mod:`.csv_io`.
"""

from __future__ import annotations

import csv
import os
from pathlib import Path
from typing import IO, Any, Iterable, Mapping

from ..core.imu import ImuSample
from ..paths import open_for_writing, text_writer
from .csv_io import STATUS_INCOMPLETE

__all__ = ["ImuCsvWriter", "IMU_COLUMNS"]

#: The header row.
IMU_COLUMNS = ("t", "site", "ax", "ay", "az", "gx", "gy", "gz", "qx", "qy", "qz", "qw")


class ImuCsvWriter:
    """Writes IMU samples to a CSV file (columns :data:`IMU_COLUMNS`).

    Raises
    ------
    OSError
        If the file cannot be created (a FIFO, device or directory is refused without blocking).
    """

    def __init__(self, path: str | os.PathLike[str], meta: Mapping[str, str] | None = None):
        self.path = Path(path)
        self._file: IO[str] | None = text_writer(open_for_writing(self.path, expected="a CSV file"))
        self._file.write("# rigid_body_sim IMU samples: one row per sample of one IMU, SI units, sensor axes\n")
        for key, value in {**(meta or {}), "status": STATUS_INCOMPLETE}.items():
            self._file.write(f"# {_one_line(key)}: {_one_line(value)}\n")
        self._csv = csv.writer(self._file)
        self._csv.writerow(IMU_COLUMNS)
        self.rows = 0

    def write(self, samples: Iterable[ImuSample]) -> None:
        """Append one row per sample."""
        if self._file is None:
            raise ValueError(f"CSV file {self.path} is closed")
        for s in samples:
            q = [repr(float(x)) for x in s.orientation_xyzw] if s.orientation_xyzw is not None else [""] * 4
            self._csv.writerow([repr(float(s.time)), s.site, *(repr(float(x)) for x in s.specific_force),
                                *(repr(float(x)) for x in s.angular_velocity), *q])
            self.rows += 1

    def fileno(self) -> int:
        if self._file is None:
            raise ValueError(f"CSV file {self.path} is closed")
        return self._file.fileno()

    def close(self, status: str = "complete") -> None:
        """End the file with ``# status: <status>`` and close it. Safe to call twice."""
        if self._file is None:
            return
        file, self._file = self._file, None
        try:
            file.write(f"# status: {_one_line(status)}\n")
            file.flush()
        finally:
            try:
                file.close()
            except OSError:
                pass

    def __enter__(self) -> "ImuCsvWriter":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()


def _one_line(value: Any) -> str:
    return " ".join(str(value).split())
