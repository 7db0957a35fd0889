"""The profilers, behind one entry point: ``python -m benchmarks.profile kernels|step|node``.

* ``kernels`` (kernels.py): the plain compiled loop with our costs added one at a time, at
  N = 1e4 and for one body; ``make bench`` writes it to results/profile_kernels.txt;
* ``step`` (step.py): cProfile of the Python side of ``apply_force_at_point`` in a frame plus
  ``step(1)``;
* ``node`` (node.py): cProfile of the node's tick in-process (needs ROS 2).
"""
