"""The step on every core: threads against one thread, one thread against the plain compiled loop.

``python -m benchmarks.threads [--quick] [--out benchmarks/results] [--performance docs/performance.md]``
writes ``threads.csv`` and ``threads.md`` (and, with ``--performance``, the block between the
``threads`` markers of that page). On the throughput problem (benchmarks/throughput.py:
tumbling asymmetric boxes, every integrator steps them, h = 1 ms), ``sim.step(k)``, medians of
≥ 5 interleaved samples (timing.py) with min–max:

* **threads**: at N = 1e5, body-steps/s of every compiled integrator with ``threads=1`` and
  ``threads=T`` (T = every core numba may use), and their ratio;
* **where parallel starts**: ``euler`` (the cheapest step, so the size where a parallel launch
  pays last) at sizes around ``kernels/parallel.MIN_BODIES``, forced serial and forced parallel;
* **one thread against the floor**: at N = 1e4, ``threads=1``, our ``euler`` and ``rk4``
  against the plain numba loop of the same step (benchmarks/floors.py): time ratio.
"""

from __future__ import annotations

import argparse
import csv
import sys
from pathlib import Path

from rigid_body_sim.core import INTEGRATORS, Simulator
from rigid_body_sim.core.kernels import parallel

from . import machine
from .throughput import DT, MAX_STEPS_PER_SAMPLE, _floor, scene
from .timing import MIN_REPEATS, Case, interleaved

BEGIN, END = "<!-- threads:begin -->", "<!-- threads:end -->"
COMPILED = tuple(name for name, m in INTEGRATORS.items() if m.code is not None)
THRESHOLD_SIZES = (1024, 2048, 4096, 8192, 16384)


def _case(key, sim: Simulator) -> Case:
    return Case(key, sim.step, sim.reset, MAX_STEPS_PER_SAMPLE)


def threads_at(count: int, threads: int, repeats: int, min_seconds: float, log=print) -> list[dict]:
    """Per compiled integrator: body-steps/s with 1 and ``threads`` threads at ``count`` bodies, and the ratio."""
    s = scene(count)
    rows = []
    for name in COMPILED:
        cases = [_case((name, t), Simulator(s, integrator=name, dt=DT, threads=t)) for t in (1, threads)]
        stats = interleaved(cases, repeats, min_seconds)
        one, many = stats[(name, 1)].rate(count), stats[(name, threads)].rate(count)
        rows.append({"table": "threads", "integrator": name, "bodies": count, "threads": threads,
                     **one.as_row("one_thread_body_steps_per_s"), **many.as_row("threads_body_steps_per_s"),
                     "ratio": many.median / one.median})
        log(f"  {name} N = {count}: {threads} threads / 1 = {rows[-1]['ratio']:.3g}")
    return rows


def threshold(threads: int, repeats: int, min_seconds: float, log=print) -> list[dict]:
    """``euler`` at THRESHOLD_SIZES: serial (threads=1) and parallel (``threads``, threshold lowered to 1)."""
    rows = []
    saved = parallel.MIN_BODIES
    try:
        for count in THRESHOLD_SIZES:
            s = scene(count)
            parallel.MIN_BODIES = 1
            par = Simulator(s, integrator="euler", dt=DT, threads=threads)
            parallel.MIN_BODIES = saved
            stats = interleaved([_case("serial", Simulator(s, integrator="euler", dt=DT, threads=1)),
                                 _case("parallel", par)], repeats, min_seconds)
            serial, many = stats["serial"].scaled(1e6), stats["parallel"].scaled(1e6)
            rows.append({"table": "threshold", "integrator": "euler", "bodies": count, "threads": threads,
                         **serial.as_row("serial_us_per_step"), **many.as_row("parallel_us_per_step"),
                         "ratio": serial.median / many.median})
            log(f"  euler N = {count}: serial / parallel = {rows[-1]['ratio']:.3g}")
    finally:
        parallel.MIN_BODIES = saved
    return rows


def against_floor(count: int, repeats: int, min_seconds: float, log=print) -> list[dict]:
    """``euler`` and ``rk4`` on one thread against their plain loops at ``count`` bodies: time ratios."""
    s = scene(count)
    rows = []
    for name in ("euler", "rk4"):
        stats = interleaved([_case("ours", Simulator(s, integrator=name, dt=DT, threads=1)), _floor(count, name)],
                            repeats, min_seconds)
        ours, floor = stats["ours"].scaled(1e9 / count), stats[("floor", name, "batched")].scaled(1e9 / count)
        rows.append({"table": "floor", "integrator": name, "bodies": count, "threads": 1,
                     **ours.as_row("ours_ns_per_body_step"), **floor.as_row("floor_ns_per_body_step"),
                     "ratio": ours.median / floor.median})
        log(f"  {name} N = {count}, one thread: ours / floor = {rows[-1]['ratio']:.3g}")
    return rows


def _r(row: dict, key: str) -> str:
    return f"{row[key]:.3g} ({row[key + '_min']:.3g}–{row[key + '_max']:.3g})"


def markdown(rows: list[dict], machine_text: str, layer: str) -> str:
    many = [r for r in rows if r["table"] == "threads"]
    thr = [r for r in rows if r["table"] == "threshold"]
    floor = [r for r in rows if r["table"] == "floor"]
    out = [f"From `python -m benchmarks.threads`, {machine.one_line()}, numba threading layer `{layer}`, "
           f"{parallel.max_threads()} threads.\n", "Machine:\n", machine_text]
    if many:
        t = many[0]["threads"]
        out += [f"**{t} threads against one**, N = {many[0]['bodies']:,} tumbling boxes, `step(k)`, body-steps/s, "
                "median (min–max):\n",
                f"| integrator | 1 thread | {t} threads | ratio |", "|---|---|---|---|"]
        out += [f"| `{r['integrator']}` | {_r(r, 'one_thread_body_steps_per_s')} | "
                f"{_r(r, 'threads_body_steps_per_s')} | {r['ratio']:.3g}× |" for r in many]
        out.append("")
    if thr:
        out += [f"**Where the parallel step starts to pay** (`euler`, {thr[0]['threads']} threads; the step runs in "
                f"parallel from `kernels/parallel.MIN_BODIES` = {parallel.MIN_BODIES} moving bodies), µs per step:\n",
                "| bodies | serial | parallel | serial / parallel |", "|---|---|---|---|"]
        out += [f"| {r['bodies']} | {_r(r, 'serial_us_per_step')} | {_r(r, 'parallel_us_per_step')} | "
                f"{r['ratio']:.3g}× |" for r in thr]
        out.append("")
    if floor:
        out += [f"**One thread against the plain compiled loop**, N = {floor[0]['bodies']:,}, ns per body-step:\n",
                "| integrator | ours, 1 thread | plain loop | ours / plain |", "|---|---|---|---|"]
        out += [f"| `{r['integrator']}` | {_r(r, 'ours_ns_per_body_step')} | {_r(r, 'floor_ns_per_body_step')} | "
                f"{r['ratio']:.3g}× |" for r in floor]
        out.append("")
    return "\n".join(out)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--quick", action="store_true", help="shorter samples (the same ≥ 5 repeats)")
    parser.add_argument("--out", type=Path, default=Path("benchmarks/results"))
    parser.add_argument("--performance", default="", help="update the threads block of this page")
    parser.add_argument("--bodies", type=int, default=100_000, help="N of the threads table")
    args = parser.parse_args(argv)
    min_seconds = 0.2 if args.quick else 0.5
    threads = parallel.max_threads()
    log = lambda s: print(s, flush=True)  # noqa: E731
    rows = (threads_at(args.bodies, threads, MIN_REPEATS, min_seconds, log)
            + threshold(threads, MIN_REPEATS, min_seconds / 2, log)
            + against_floor(10_000, MIN_REPEATS, min_seconds, log))
    args.out.mkdir(parents=True, exist_ok=True)
    keys = list(dict.fromkeys(k for r in rows for k in r))
    with (args.out / "threads.csv").open("w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=keys)
        writer.writeheader()
        writer.writerows(rows)
    import numba

    text = markdown(rows, machine.text(), numba.threading_layer())
    (args.out / "threads.md").write_text(text)
    if args.performance:
        page = Path(args.performance)
        body = page.read_text()
        if BEGIN not in body or END not in body:
            raise SystemExit(f"{page}: no {BEGIN} … {END} block to update")
        head, rest = body.split(BEGIN, 1)
        page.write_text(f"{head}{BEGIN}\n{text}{END}{rest.split(END, 1)[1]}")
    log(f"wrote {args.out / 'threads.csv'}, {args.out / 'threads.md'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
