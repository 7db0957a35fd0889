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

import os
from typing import Iterable, Mapping

from ..core.imu import ImuSample
from .csv_io import CommentedCsvFile

__all__ = ["ImuCsvWriter", "IMU_COLUMNS"]

#: The header row.
IMU_COLUMNS = ("t", "site", "ax", "ay", "az", "gx", "gy", "gz", "qx", "qy", "qz", "qw")


class ImuCsvWriter(CommentedCsvFile):
    """Writes IMU samples to a CSV file (columns :data:`IMU_COLUMNS`).

    Raises
    ------
    OSError
        If the file cannot be created (a FIFO, device or directory is refused without blocking).
    """

    def __init__(self, path: str | os.PathLike[str], meta: Mapping[str, str] | None = None):
        super().__init__(path, "rigid_body_sim IMU samples: one row per sample of one IMU, SI units, sensor axes",
                         meta)
        self._csv.writerow(IMU_COLUMNS)

    def write(self, samples: Iterable[ImuSample]) -> None:
        """Append one row per sample."""
        if self._file is None:
            raise ValueError(f"CSV file {self.path} is closed")
        for s in samples:
            q = [repr(float(x)) for x in s.orientation_xyzw] if s.orientation_xyzw is not None else [""] * 4
            self._csv.writerow([repr(float(s.time)), s.site, *(repr(float(x)) for x in s.specific_force),
                                *(repr(float(x)) for x in s.angular_velocity), *q])
            self.rows += 1
