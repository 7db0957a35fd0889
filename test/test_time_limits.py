"""The per-test time limits of test/conftest.py, for the one case their watchdog thread cannot reach."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
import time
from pathlib import Path

BLOCKED = '''
import ctypes

import pytest


@pytest.mark.timeout(1)
def test_blocked():
    libc = ctypes.PyDLL(None)  # PyDLL: the call keeps the GIL
    mutex = ctypes.create_string_buffer(64)  # zeroed: a default pthread mutex
    libc.pthread_mutex_lock(mutex)
    libc.pthread_mutex_lock(mutex)  # locked again by its owner: blocks for ever, deaf to signals
'''


def test_a_test_blocked_in_c_with_the_gil_held_ends_its_process_and_leaves_its_stacks(tmp_path: Path) -> None:
    """A test whose C call blocks for ever holding the GIL (as a DDS participant's deletion waiting on its listener
    did inside rclpy's destroy_node): its 1 s limit's alarm and the watchdog thread cannot run, and faulthandler's
    thread ends the process 2 × the grace (1 s here) after the limit, exit code 1, with every thread's stack in
    rigid_body_sim_stuck_<pid>.txt naming the test and the line it is blocked on."""
    (tmp_path / "conftest.py").write_text((Path(__file__).parent / "conftest.py").read_text())
    (tmp_path / "test_blocked.py").write_text(textwrap.dedent(BLOCKED))
    env = dict(os.environ, RIGID_BODY_SIM_WATCHDOG_GRACE_S="1", RIGID_BODY_SIM_STUCK_DIR=str(tmp_path))
    began = time.monotonic()
    run = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-p", "no:xdist",
                          "--rootdir", str(tmp_path), str(tmp_path / "test_blocked.py")],
                         cwd=tmp_path, env=env, capture_output=True, text=True, timeout=60)
    took = time.monotonic() - began
    assert run.returncode == 1, run.stdout + run.stderr
    assert 3.0 <= took < 30.0
    stuck = list(tmp_path.glob("rigid_body_sim_stuck_*.txt"))
    assert len(stuck) == 1
    text = stuck[0].read_text()
    assert "test_blocked.py::test_blocked is still running 2 s after its 1 s limit" in text
    assert 'test_blocked.py", line 12 in test_blocked' in text
