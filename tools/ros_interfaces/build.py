"""Build a ROS 2 message package into a virtualenv, without CMake, from the rosidl generators on PyPI.

Some standard interface packages have no wheel on PyPI (tf2_msgs among them), while every ROS 2
install has them. This script gives the project's virtualenv the same package, so the node's
``/tf`` output can be tested here against a real subscriber: it runs the rosidl generators that the
``ros-rosidl-*`` wheels install (C structs, the C, introspection and Fast DDS type supports, the
Python bindings), compiles their output with the system C/C++ compiler against the headers and
libraries of the installed message wheels, and installs the result the way those wheels lay out
theirs:

- ``<prefix>/lib/lib<pkg>__rosidl_{generator_c,typesupport_c,typesupport_introspection_c,
  typesupport_fastrtps_c,generator_py}.so``
- ``<site-packages>/<pkg>/`` with the ``msg`` module and the ``<pkg>_s__rosidl_typesupport_*``
  extension modules
- ``<prefix>/share/<pkg>/`` (package.xml, msg/*.msg, *.idl, *.json) and its ament index entries.

Usage: ``<venv>/bin/python tools/ros_interfaces/build.py tf2_msgs`` (the Makefile's set-up does
this). The message definitions are in ``tools/ros_interfaces/<pkg>/msg/``; each package lists the
interface packages it depends on in :data:`PACKAGES`.
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import sysconfig
import tempfile
from pathlib import Path

#: package -> the interface packages its messages use (their headers and libraries are linked).
PACKAGES = {
    "tf2_msgs": ("geometry_msgs", "std_msgs", "builtin_interfaces"),
}

HERE = Path(__file__).resolve().parent
VERSION = "0.0.0"


def _say(text: str) -> None:
    print(f"[ros_interfaces] {text}", flush=True)


def _generate(package: str, interface_files: list[str], prefix: Path, out: Path) -> None:
    """Run the rosidl generators (through their Python API: the `rosidl` command refuses to run
    when a package is installed twice, egg-info beside dist-info, as the ROS wheels are)."""
    os.environ.setdefault("AMENT_PREFIX_PATH", str(prefix))
    from rosidl_generator_c.cli import GenerateC
    from rosidl_generator_py.cli import GeneratePython
    from rosidl_typesupport_c.cli import GenerateCTypesupport
    from rosidl_typesupport_fastrtps_c.cli import GenerateFastRTPSCTypesupport
    from rosidl_typesupport_introspection_c.cli import GenerateIntrospectionCTypesupport

    include_paths = [str(prefix / "share")]
    for generator, sub in ((GenerateC, "c"), (GenerateCTypesupport, "ts_c"),
                           (GenerateIntrospectionCTypesupport, "ts_introspection_c"),
                           (GenerateFastRTPSCTypesupport, "ts_fastrtps_c"), (GeneratePython, "py")):
        generator(sub).generate(package, interface_files, include_paths, out / sub)


def _compile(sources: list[Path], output: Path, flags: list[str], libraries: list[str], cxx: bool) -> None:
    compiler = os.environ.get("CXX", "g++") if cxx else os.environ.get("CC", "gcc")
    command = [compiler, "-shared", "-fPIC", "-O2", *(["-std=c++17"] if cxx else []), *flags,
               *map(str, sources), "-o", str(output), *libraries]
    result = subprocess.run(command, capture_output=True, text=True)
    if result.returncode != 0:
        raise SystemExit(f"[ros_interfaces] compiling {output.name} failed:\n{' '.join(command)}\n{result.stderr}")


def build(package: str, prefix: Path) -> None:
    """Generate, compile and install ``package`` into the environment at ``prefix``."""
    if package not in PACKAGES:
        raise SystemExit(f"[ros_interfaces] unknown package {package!r}; known: {', '.join(PACKAGES)}")
    dependencies = PACKAGES[package]
    source = HERE / package
    site_packages = Path(sysconfig.get_paths()["purelib"])
    lib = prefix / "lib"
    messages = sorted(p.relative_to(source).as_posix() for p in (source / "msg").glob("*.msg"))
    with tempfile.TemporaryDirectory(prefix=f"{package}-") as tmp:
        work = Path(tmp)
        gen = work / "gen"
        _generate(package, [f"{source}:{m}" for m in messages], prefix, gen)

        # Headers as an install lays them out: <include>/<package>/msg/...
        include = work / "include"
        staged = include / package / "msg"
        for sub in ("c", "ts_introspection_c", "ts_fastrtps_c"):
            shutil.copytree(gen / sub / "msg", staged, dirs_exist_ok=True, ignore=shutil.ignore_patterns("*.c", "*.cpp"))
        flags = [f"-I{include}", f"-I{prefix / 'include'}",
                 *(f"-I{d}" for d in sorted((prefix / "include").iterdir()) if d.is_dir()),
                 f"-I{sysconfig.get_paths()['include']}", f"-I{_numpy_include()}",
                 f"-L{lib}", f"-L{work}", f"-Wl,-rpath,{lib}"]

        def libs(kind: str) -> list[str]:
            return [f"-l{dep}__{kind}" for dep in dependencies]

        built = work / "lib"
        built.mkdir()
        flags.append(f"-L{built}")
        name = f"lib{package}__rosidl"
        _compile(sorted((gen / "c" / "msg" / "detail").glob("*.c")), built / f"{name}_generator_c.so", flags,
                 [*libs("rosidl_generator_c"), "-lrosidl_runtime_c", "-lrcutils"], cxx=False)
        own_c = f"-l{package}__rosidl_generator_c"
        _compile(sorted((gen / "ts_introspection_c" / "msg" / "detail").glob("*.c")),
                 built / f"{name}_typesupport_introspection_c.so", flags,
                 [own_c, *libs("rosidl_typesupport_introspection_c"), "-lrosidl_runtime_c"], cxx=False)
        _compile(sorted((gen / "ts_fastrtps_c" / "msg" / "detail").glob("*.cpp")),
                 built / f"{name}_typesupport_fastrtps_c.so", flags,
                 [own_c, *libs("rosidl_typesupport_fastrtps_c"), *libs("rosidl_generator_c"),
                  "-lrosidl_typesupport_fastrtps_c", "-lrosidl_typesupport_fastrtps_cpp", "-lfastcdr",
                  "-lrosidl_runtime_c", "-lrmw"], cxx=True)
        _compile(sorted((gen / "ts_c" / "msg").glob("*.cpp")), built / f"{name}_typesupport_c.so", flags,
                 [own_c, "-lrosidl_typesupport_c", "-lrosidl_runtime_c", "-lrcpputils", "-lrcutils"], cxx=True)
        _compile(sorted((gen / "py" / "msg").glob("*_s.c")), built / f"{name}_generator_py.so", flags,
                 [own_c, f"-l{package}__rosidl_typesupport_c", *libs("rosidl_generator_py"), *libs("rosidl_generator_c"),
                  "-lrosidl_runtime_c"], cxx=False)

        # The Python package: generated modules plus one extension module per type support.
        py_dir = work / "py" / package
        shutil.copytree(gen / "py" / "msg", py_dir / "msg", ignore=shutil.ignore_patterns("*.c"))
        (py_dir / "__init__.py").write_text("")
        for support in ("rosidl_typesupport_c", "rosidl_typesupport_fastrtps_c", "rosidl_typesupport_introspection_c"):
            _compile([gen / "py" / f"_{package}_s.ep.{support}.c"], py_dir / f"{package}_s__{support}.so", flags,
                     [f"-l{package}__rosidl_generator_py", f"-l{package}__{support}", own_c,
                      f"-l{package}__rosidl_typesupport_c", "-lrosidl_runtime_c", "-lrosidl_typesupport_c"], cxx=False)

        # Install.
        for so in built.iterdir():
            shutil.copy2(so, lib / so.name)
        shutil.rmtree(site_packages / package, ignore_errors=True)
        shutil.copytree(py_dir, site_packages / package)
        share = prefix / "share" / package
        shutil.rmtree(share, ignore_errors=True)
        (share / "msg").mkdir(parents=True)
        for m in messages:
            shutil.copy2(source / m, share / m)
            stem = Path(m).stem
            for suffix in (".idl", ".json"):
                found = list(gen.glob(f"*/**/msg/{stem}{suffix}"))
                if found:
                    shutil.copy2(found[0], share / "msg" / f"{stem}{suffix}")
        (share / "package.xml").write_text(_package_xml(package, dependencies))
        index = prefix / "share" / "ament_index" / "resource_index"
        for resource, content in (("packages", ""), ("rosidl_interfaces", "\n".join(messages) + "\n")):
            (index / resource).mkdir(parents=True, exist_ok=True)
            (index / resource / package).write_text(content)
    _say(f"installed {package} ({', '.join(Path(m).stem for m in messages)}) into {prefix}")


def _numpy_include() -> str:
    import numpy

    return numpy.get_include()


def _package_xml(package: str, dependencies: tuple[str, ...]) -> str:
    depends = "\n".join(f"  <depend>{d}</depend>" for d in dependencies)
    return f"""<?xml version="1.0"?>
<package format="3">
  <name>{package}</name>
  <version>{VERSION}</version>
  <description>{package} built from its message definitions by rigid_body_sim's tools/ros_interfaces/build.py.</description>
  <maintainer email="none@example.invalid">rigid_body_sim</maintainer>
  <license>Apache License 2.0</license>
{depends}
  <member_of_group>rosidl_interface_packages</member_of_group>
  <export><build_type>ament_cmake</build_type></export>
</package>
"""


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("packages", nargs="+", choices=sorted(PACKAGES))
    args = parser.parse_args(argv)
    for package in args.packages:
        build(package, Path(sys.prefix))
    return 0


if __name__ == "__main__":
    sys.exit(main())
