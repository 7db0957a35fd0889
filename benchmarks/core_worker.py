"""The child of benchmarks/core_compare.py: steps scenes with whichever ``rigid_body_sim`` it imports.

Protocol: one JSON request per line on stdin, one JSON answer per line on stdout.
``{"cmd": "where"}`` → the file of the imported package and its integrators; ``{"cmd": "setup", "count", "integrator",
"dt"}`` → a handle to a Simulator on the throughput scene; ``{"cmd": "time", "handle", "steps"}``
→ ``sim.reset()``, then the seconds of ``sim.step(steps)`` alone (garbage collector off).
"""

from __future__ import annotations

import gc
import json
import sys
import time


def main() -> int:
    import rigid_body_sim
    from rigid_body_sim.core import INTEGRATORS, Simulator

    from benchmarks.throughput import scene

    sims = []
    for line in sys.stdin:
        try:
            request = json.loads(line)
            if request["cmd"] == "where":
                answer = {"file": rigid_body_sim.__file__, "integrators": list(INTEGRATORS)}
            elif request["cmd"] == "setup":
                sim = Simulator(scene(request["count"]), integrator=request["integrator"], dt=request["dt"])
                sim.step(1)  # compile or load the kernels now
                sims.append(sim)
                answer = {"handle": len(sims) - 1}
            elif request["cmd"] == "time":
                sim = sims[request["handle"]]
                sim.reset()
                gc.disable()
                t0 = time.perf_counter()
                sim.step(request["steps"])
                seconds = time.perf_counter() - t0
                gc.enable()
                answer = {"seconds": seconds}
            else:
                answer = {"error": f"unknown command {request['cmd']!r}"}
        except Exception as exc:  # report to the parent, keep serving
            answer = {"error": f"{type(exc).__name__}: {exc}"}
        sys.stdout.write(json.dumps(answer) + "\n")
        sys.stdout.flush()
    return 0


if __name__ == "__main__":
    sys.exit(main())
