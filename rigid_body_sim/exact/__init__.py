"""Exact references (closed forms) that tests, benchmarks and the offline plots check the simulator against.

Nothing the simulator runs imports this package (test_core_purity.py checks it), so a reference
and the production code it checks never share an implementation: a mistake in one shows up as
a disagreement, not as agreement. Use ``from rigid_body_sim.exact import closed_form``.
"""
