"""Package data ``rigid_body_sim.config`` (setup.py maps it to this directory): the default scene and
the other scene and parameter files, found with importlib.resources (rigid_body_sim/package_data.py)."""
