"""``python -m benchmarks.profile kernels [--out FILE] | step [INTEGRATOR] [FRAME] | node [BODIES]``."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.profile", description=__doc__)
    sub = parser.add_subparsers(dest="what", required=True)
    kernels = sub.add_parser("kernels", help="the plain loop with our costs added one at a time")
    kernels.add_argument("--out", type=Path, help="write the report here too (results/profile_kernels.txt)")
    step = sub.add_parser("step", help="cProfile of apply_force_at_point in a frame + step(1)")
    step.add_argument("integrator", nargs="?", default="rk4")
    step.add_argument("frame", nargs="?", default="b/corner")
    node = sub.add_parser("node", help="cProfile of the node's tick, in-process")
    node.add_argument("bodies", nargs="?", type=int, default=100)
    args = parser.parse_args(argv)
    if args.what == "kernels":
        from .kernels import report

        text = report()
        if args.out:
            args.out.write_text(text)
    elif args.what == "step":
        from .step import profile

        text = profile(args.integrator, args.frame)
    else:
        from .node import profile, profile_spin

        text = profile(args.bodies) + "\n" + profile_spin(args.bodies)
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
