"""Offline runs, CSV files, MCAP recordings and plots, on top of the core: no ROS needed.

``run.py`` steps a scene as fast as possible and samples it; ``csv_io.py`` writes and reads the
CSV files of a run; ``recording.py`` writes (and reads back) MCAP recordings with ROS 2 message
encodings (mcap + mcap-ros2-support; the message definitions are in ``msgdefs.py``);
``reference.py`` gives the closed-form motion where a scene has one; ``plotting.py`` draws a
run with matplotlib. Nothing here imports rclpy or a ROS message package (a test checks it),
so ``rigid-body-sim run`` works on a machine without ROS. The CLI is ``rigid_body_sim/cli.py``.
"""
