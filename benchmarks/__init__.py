"""Benchmarks of rigid_body_sim: work-precision, throughput and node timing, beside MuJoCo.

Run with ``.venv/bin/python -m benchmarks.run --quick|--full --out benchmarks/results/``
(``make bench`` / ``make bench-full``). Not part of the test command. MuJoCo is optional
(``pip install -e .[bench]``); without it the MuJoCo columns are left out and say so.
"""
