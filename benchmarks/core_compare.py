"""Two versions of the core in one run: this checkout's and another git revision's, interleaved.

"Throughput must not fall after a rewrite" compares two versions of the code; figures from two
runs on a shared machine do not compare. Here the other version runs in a child process:
``git archive <rev> rigid_body_sim`` is exported once into ``benchmarks/.cache/core-<sha>/``
(its numba cache is kept there, so only the first run compiles it), and the child imports it
ahead of this checkout (``PYTHONPATH``). The parent sends it "step the scene k times" and the
child answers with the seconds of that call alone; its samples are interleaved with this
checkout's (timing.interleaved), so both see the same load.

The child uses only the public API (``load_scene``, ``Simulator(scene, integrator=, dt=)``,
``reset``, ``step``), which both versions share.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

from .timing import Case

REPO = Path(__file__).resolve().parent.parent
CACHE = Path(__file__).resolve().parent / ".cache"


def export(rev: str) -> tuple[Path, str]:
    """(directory holding rev's ``rigid_body_sim``, full sha), exported once per sha."""
    sha = subprocess.run(["git", "rev-parse", "--verify", f"{rev}^{{commit}}"], cwd=REPO, capture_output=True,
                         text=True, check=True).stdout.strip()
    target = CACHE / f"core-{sha[:12]}"
    CACHE.mkdir(parents=True, exist_ok=True)
    (CACHE / ".gitignore").write_text("*\n")  # never committed
    if not (target / "rigid_body_sim" / "__init__.py").exists():
        target.mkdir(parents=True, exist_ok=True)
        archive = subprocess.run(["git", "archive", "--format=tar", sha, "rigid_body_sim"], cwd=REPO,
                                 capture_output=True, check=True).stdout
        subprocess.run(["tar", "-x", "-C", str(target)], input=archive, check=True)
    return target, sha


class OtherCore:
    """A child process stepping scenes with another revision's core."""

    def __init__(self, rev: str):
        self.path, self.sha = export(rev)
        env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(self.path), str(REPO)]))
        self.proc = subprocess.Popen([sys.executable, "-m", "benchmarks.core_worker"], cwd=str(self.path), env=env,
                                     stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True, bufsize=1)
        where = self._ask({"cmd": "where"})
        self.where, self.integrators = where["file"], tuple(where["integrators"])
        if not self.where.startswith(str(self.path)):
            self.close()
            raise RuntimeError(f"the child imported rigid_body_sim from {self.where}, not from {self.path}")

    def _ask(self, request: dict) -> dict:
        assert self.proc.stdin and self.proc.stdout
        self.proc.stdin.write(json.dumps(request) + "\n")
        line = self.proc.stdout.readline()
        if not line:
            raise RuntimeError(f"the core worker for {self.sha[:12]} exited (code {self.proc.poll()})")
        answer = json.loads(line)
        if "error" in answer:
            raise RuntimeError(f"core worker {self.sha[:12]}: {answer['error']}")
        return answer

    def case(self, key, count: int, integrator: str, dt: float, max_units: int) -> Case:
        """A batched ``step(k)`` case of the throughput scene (benchmarks.throughput.scene) in the child."""
        handle = self._ask({"cmd": "setup", "count": count, "integrator": integrator, "dt": dt})["handle"]
        return Case(key, max_units=max_units,
                    timed=lambda k: self._ask({"cmd": "time", "handle": handle, "steps": int(k)})["seconds"])

    def close(self) -> None:
        if self.proc.poll() is None:
            assert self.proc.stdin
            self.proc.stdin.close()
            try:
                self.proc.wait(timeout=30)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()


def compare_throughput(rev: str, count: int, repeats: int, min_seconds: float, log=print) -> list[dict]:
    """Body-steps/s of ``step(k)`` on the throughput scene, this checkout vs ``rev``, per integrator both have.

    ``reference`` is left out (scipy per body: seconds per step at N = 1e4).
    """
    from rigid_body_sim.core import INTEGRATORS, Simulator

    from .throughput import DT, MAX_STEPS_PER_SAMPLE, scene
    from .timing import interleaved

    log(f"  exporting and starting the core of {rev} (its first run compiles its kernels: minutes)")
    other = OtherCore(rev)
    try:
        names = [n for n in INTEGRATORS if n in other.integrators and n != "reference"]
        s = scene(count)
        cases = []
        for name in names:
            sim = Simulator(s, integrator=name, dt=DT, threads=1)
            cases.append(Case(("this", name), sim.step, sim.reset, MAX_STEPS_PER_SAMPLE))
            cases.append(other.case(("base", name), count, name, DT, MAX_STEPS_PER_SAMPLE))
        stats = interleaved(cases, repeats, min_seconds)
    finally:
        other.close()
    rows = []
    for name in names:
        this, base = stats[("this", name)].rate(count), stats[("base", name)].rate(count)
        rows.append({"integrator": name, "bodies": count, "baseline": f"{rev} ({other.sha[:10]})",
                     **this.as_row("this_body_steps_per_s"), **base.as_row("base_body_steps_per_s"),
                     "ratio": this.median / base.median})
    log("  core comparison done")
    return rows
