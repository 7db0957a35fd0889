"""Command-line tools built on the core (no ROS): ``python -m rigid_body_sim.tools.<name>``."""
