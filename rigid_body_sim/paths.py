"""Former home of :mod:`rigid_body_sim.safe_open` and :mod:`rigid_body_sim.package_data`.

Kept only so that modules not yet moved to the new names keep importing; new code imports
from those two modules.
"""

from .package_data import DEFAULT_SCENE_FILE, config_dir, default_scene_path
from .safe_open import (FileTooLargeError, NotRegularFileError, check_writable_path, file_kind, open_for_reading,
                        open_for_writing, read_regular_file, same_file, text_writer)

__all__ = ["DEFAULT_SCENE_FILE", "config_dir", "default_scene_path", "NotRegularFileError", "FileTooLargeError",
           "file_kind", "open_for_reading", "read_regular_file", "open_for_writing", "check_writable_path",
           "same_file", "text_writer"]
