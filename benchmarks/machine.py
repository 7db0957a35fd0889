"""The machine a benchmark ran on: CPU model, vector extensions, cores, load, library versions.

Printed at the top of every results file: on a shared machine only ratios measured in the same
run are comparable, and figures from two CPUs (an Intel Xeon and an AMD EPYC differ by 1.5–3×
on the same kernel) are not.
"""

from __future__ import annotations

import os
import platform
import subprocess
from importlib import metadata
from pathlib import Path

#: Packages whose versions change the figures.
LIBRARIES = ("numpy", "scipy", "numba", "llvmlite", "mujoco")


def _cpuinfo() -> dict[str, str]:
    """The first processor's fields of /proc/cpuinfo (Linux); empty elsewhere."""
    try:
        text = Path("/proc/cpuinfo").read_text()
    except OSError:
        return {}
    fields: dict[str, str] = {}
    for line in text.split("\n\n", 1)[0].splitlines():
        key, _, value = line.partition(":")
        fields[key.strip()] = value.strip()
    return fields


def _version(package: str) -> str:
    try:
        return metadata.version(package)
    except metadata.PackageNotFoundError:
        return "not installed"


def describe() -> dict[str, object]:
    """CPU model, AVX2/AVX-512 support, logical CPUs, OpenBLAS core override, load, Python and library versions."""
    info = _cpuinfo()
    flags = set(info.get("flags", "").split())
    avx512 = sorted(f for f in flags if f.startswith("avx512"))
    try:
        load = tuple(float(x) for x in Path("/proc/loadavg").read_text().split()[:3])
    except OSError:
        load = ()
    return {
        "cpu": info.get("model name", platform.processor() or "unknown"),
        "logical_cpus": os.cpu_count(),
        "avx2": "avx2" in flags,
        "avx512": bool(avx512),
        "avx512_subsets": " ".join(avx512),
        "openblas_coretype": os.environ.get("OPENBLAS_CORETYPE", "(auto)"),
        "load_average": load,
        "python": platform.python_version(),
        **{name: _version(name) for name in LIBRARIES},
    }


def text(info: dict[str, object] | None = None) -> str:
    """A few indented lines for a markdown file (a code block)."""
    d = describe() if info is None else info
    avx = "AVX-512 (" + str(d["avx512_subsets"]) + ")" if d["avx512"] else ("AVX2, no AVX-512" if d["avx2"] else "no AVX2")
    load = " ".join(f"{x:.2f}" for x in d["load_average"])  # type: ignore[union-attr]
    libs = ", ".join(f"{name} {d[name]}" for name in LIBRARIES)
    return (f"    CPU: {d['cpu']}, {d['logical_cpus']} logical CPUs, {avx}\n"
            f"    OPENBLAS_CORETYPE: {d['openblas_coretype']}\n"
            f"    Python {d['python']}, {libs}\n"
            f"    load average (1, 5, 15 min) when written: {load} — a shared machine: compare ratios within one run\n")


def one_line(info: dict[str, object] | None = None) -> str:
    """The machine in one line, for a headline."""
    d = describe() if info is None else info
    return f"{d['cpu']}, {d['logical_cpus']} CPUs, {'AVX-512' if d['avx512'] else 'no AVX-512'}, MuJoCo {d['mujoco']}"


def git(*args: str) -> str:
    """The output of ``git *args`` in this repository ("?" without git or outside a checkout):
    the commit a benchmark's results name."""
    try:
        return subprocess.run(["git", *args], cwd=Path(__file__).resolve().parent.parent, capture_output=True,
                              text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "?"
