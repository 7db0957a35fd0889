"""Hostile input to the scene loader and the ``rigid-body-sim`` command: never a hang, a memory
blow-up or a traceback.

Each case is input that, unchecked, ends badly (each docstring says how); the test states what
must happen: a clear error naming the key path and what was expected, in bounded time and
memory. Time and memory are measured in a child process (its own peak RSS and CPU time from
``wait4``), never in this pytest process, and the bounds are generous enough for a loaded
2-core machine while far below what the unbounded behaviour costs (an alias bomb expanded
passes 4 GB within a minute).

The node-side halves (a refused scene change keeps the node ticking, signals under flood) are
tested with the node.
"""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
import textwrap
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

from rigid_body_sim.core import SceneError, Simulator, load_scene
from rigid_body_sim.core import scene as scene_module

REPO = Path(__file__).resolve().parents[1]
GOOD_BODY = "{mass: 1.0, inertia: {sphere: 0.5}}"

# --------------------------------------------------------------------------- a bounded child


#: Runs argv[1:] as a child, waits for it with wait4 and prints its peak RSS (KiB) and CPU time
#: as the last line of stderr, so each case is measured alone.
_MEASURE = textwrap.dedent("""\
    import json, os, sys
    pid = os.fork()
    if pid == 0:
        os.execv(sys.argv[1], sys.argv[1:])
    _, status, usage = os.wait4(pid, 0)
    sys.stderr.write("\\nMEASURED " + json.dumps({"rss_kib": usage.ru_maxrss, "cpu_s": usage.ru_utime + usage.ru_stime,
                     "code": os.waitstatus_to_exitcode(status)}) + "\\n")
""")


@dataclass
class Outcome:
    code: int | None  # None: killed at the time limit
    stdout: str
    stderr: str
    wall_s: float
    cpu_s: float
    peak_rss_mb: float


def run_measured(argv: list[str], timeout_s: float = 60.0, **kwargs) -> Outcome:
    """Run ``argv`` in a child (own session), kill it at ``timeout_s``; its peak RSS and CPU time."""
    start = time.monotonic()
    proc = subprocess.Popen([sys.executable, "-c", _MEASURE, *argv], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, start_new_session=True, **kwargs)
    try:
        out, err = proc.communicate(timeout=timeout_s)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        out, err = proc.communicate()
        return Outcome(None, out, err, time.monotonic() - start, float("nan"), float("nan"))
    wall = time.monotonic() - start
    head, _, measured = err.rpartition("\nMEASURED ")
    info = json.loads(measured)
    return Outcome(info["code"], out, head, wall, info["cpu_s"], info["rss_kib"] / 1024.0)


def cli(*args: str) -> list[str]:
    return [sys.executable, "-m", "rigid_body_sim.cli", *args]


def write(tmp_path: Path, text: str | bytes, name: str = "scene.yaml") -> Path:
    path = tmp_path / name
    if isinstance(text, bytes):
        path.write_bytes(text)
    else:
        path.write_text(text, encoding="utf-8")
    return path


# --------------------------------------------------------------------------- alias bombs


def _bomb(levels: int = 9, width: int = 10) -> str:
    """A flow list whose anchors nest ``levels`` deep, ``width`` aliases each: width**levels leaves."""
    items = ["&a0 [" + ", ".join(["1"] * width) + "]"]
    items += [f"&a{i} [" + ", ".join([f"*a{i - 1}"] * width) + "]" for i in range(1, levels)]
    return "[" + ", ".join(items) + "]"


BOMBS = {
    "gravity": f"gravity: {_bomb()}\nbodies: {{b: {GOOD_BODY}}}\n",
    "mass": f"bodies: {{b: {{mass: {_bomb()}, inertia: {{sphere: 1}}}}}}\n",
    "bodies": f"bodies: {_bomb()}\n",
    "body": f"bodies: {{b: {_bomb()}}}\n",
    "wrenches": f"bodies: {{b: {GOOD_BODY}}}\nwrenches: {_bomb()}\n",
    "merge-keys": "bodies: {b: " + "{" + ", ".join(
        ["x0: &m0 {mass: 1.0}"] + [f"x{i}: &m{i} {{<<: [{', '.join([f'*m{i - 1}'] * 10)}]}}" for i in range(1, 9)]
    ) + "}}\n",
}


@pytest.mark.parametrize("where", list(BOMBS))
def test_alias_bomb_is_refused_in_bounded_time_and_memory(tmp_path: Path, where: str) -> None:
    """~500 bytes that expand to 10⁹ nodes (expanded: 4 GB in 60 s and no end) are refused at once."""
    path = write(tmp_path, BOMBS[where])
    assert path.stat().st_size < 700
    result = run_measured(cli("check", str(path)), timeout_s=60.0)
    print(f"alias bomb in {where}: exit {result.code}, wall {result.wall_s:.2f} s, cpu {result.cpu_s:.2f} s, "
          f"peak RSS {result.peak_rss_mb:.0f} MB")
    assert result.code == 1, result.stderr[-2000:]
    assert "Traceback" not in result.stderr
    assert re.search(r"expected a document of at most 10,000,000 nodes with aliases expanded", result.stderr)
    assert len(result.stderr) < 1000
    assert result.peak_rss_mb < 200  # the required bound; the check imports only the loader
    assert result.cpu_s < 10  # generous for a loaded machine: expanding 1e9 nodes takes minutes and gigabytes


def test_alias_bomb_in_process_is_refused_with_the_key_path(tmp_path: Path) -> None:
    path = write(tmp_path, BOMBS["gravity"])
    with pytest.raises(SceneError, match=re.escape(f"{path}: gravity[") + r".*expected a document of at most"):
        load_scene(path)


def test_recursive_alias_is_refused(tmp_path: Path) -> None:
    path = write(tmp_path, f"bodies: &b {{b: {GOOD_BODY}, c: *b}}\n")
    with pytest.raises(SceneError, match=re.escape(f"{path}: bodies.c: expected an alias to a finished node")):
        load_scene(path)


def test_error_messages_show_a_bounded_value() -> None:
    """What an error shows of a value is bounded, however large or shared the value is."""
    leaf = [1.0] * 10
    for _ in range(8):  # 10⁹ elements through shared references, as an alias bomb builds them
        leaf = [leaf] * 10
    for data, key in (({"gravity": leaf, "bodies": {"b": {"mass": 1.0, "inertia": {"sphere": 1.0}}}}, "gravity"),
                      ({"bodies": {"b": {"mass": leaf, "inertia": {"sphere": 1.0}}}}, "bodies.b.mass"),
                      ({"bodies": {"b": {"mass": "x" * 10**6, "inertia": {"sphere": 1.0}}}}, "bodies.b.mass"),
                      ({"bodies": {"b": {"mass": 10**5000, "inertia": {"sphere": 1.0}}}}, "bodies.b.mass")):
        start = time.process_time()
        with pytest.raises(SceneError, match=re.escape(f"<dict>: {key}: expected")) as info:
            load_scene(data)
        assert time.process_time() - start < 1.0
        assert len(str(info.value)) < 400, str(info.value)[:600]


# --------------------------------------------------------------------------- nesting, huge integers


@pytest.mark.parametrize("levels", [1000, 100_000])
def test_deep_nesting_is_a_scene_error(tmp_path: Path, levels: int) -> None:
    """~1000 nested flow lists (deep enough for a RecursionError in the YAML composer) are a SceneError."""
    path = write(tmp_path, "bodies: {b: {mass: " + "[" * levels + "]" * levels + ", inertia: {sphere: 1}}}\n")
    with pytest.raises(SceneError, match=re.escape(f"{path}: bodies.b.mass") + r".*expected nesting at most 32 levels"):
        load_scene(path)


@pytest.mark.parametrize(("number", "shown"), [
    ("9" * 400, "an integer of 400 digits"),
    ("-" + "9" * 400, "an integer of 400 digits"),
    ("9" * 5000, "an integer of 5000 digits"),
    ("0x" + "f" * 1000, "an integer of 1205 digits"),
    ("1e400", "inf"),
], ids=["400-digits", "negative", "5000-digits", "hex", "float-overflow"])
def test_huge_numbers_are_scene_errors_naming_the_key(tmp_path: Path, number: str, shown: str) -> None:
    """A 400-digit or a 5000-digit integer (OverflowError, ValueError in float()) is a SceneError naming the key."""
    path = write(tmp_path, f"bodies: {{b: {{mass: {number}, inertia: {{sphere: 1}}}}}}\n")
    with pytest.raises(SceneError, match=re.escape(f"{path}: bodies.b.mass: expected") + ".*" + re.escape(shown)):
        load_scene(path)


def test_huge_integers_in_vectors_are_scene_errors(tmp_path: Path) -> None:
    path = write(tmp_path, f"gravity: [0, 0, {'9' * 400}]\nbodies: {{b: {GOOD_BODY}}}\n")
    with pytest.raises(SceneError, match=re.escape(f"{path}: gravity: expected")):
        load_scene(path)
    with pytest.raises(SceneError, match=re.escape("<dict>: bodies.b.inertia.box: expected")):
        load_scene({"bodies": {"b": {"mass": 1.0, "inertia": {"box": [1, 10**400, 1]}}}})


# --------------------------------------------------------------------------- names and ROS topics


def test_long_body_name_is_refused_at_load(tmp_path: Path) -> None:
    """A 250-character body name (too long for its topics' names) is refused at load."""
    name = "b" * 250
    path = write(tmp_path, f"bodies: {{{name}: {GOOD_BODY}}}\n")
    with pytest.raises(SceneError, match=re.escape(f"{path}: bodies.{'b' * 64}")
                       + r".*expected a name of at most 63 characters.*got 250"):
        load_scene(path)
    site = "s" * 64
    with pytest.raises(SceneError, match=r"bodies\.b\.sites\.s+: expected a name of at most 63 characters"):
        load_scene({"bodies": {"b": {"mass": 1.0, "inertia": {"sphere": 1.0}, "sites": {site: {"position": [0, 0, 0]}}}}})


def test_longest_names_make_valid_ros_topics_under_the_documented_namespace() -> None:
    """The name limit leaves room for ``<ns>/<body>/<site>/imu`` and ``<ns>/<body>/impulse`` (ROS: ≤ 247 characters)."""
    pytest.importorskip("rclpy")
    from rclpy.validate_full_topic_name import validate_full_topic_name

    body, site = "B" * scene_module.MAX_NAME_LENGTH, "s" * scene_module.MAX_NAME_LENGTH
    namespace = "/" + "n" * (scene_module.MAX_NAMESPACE_LENGTH - 1)
    scene = load_scene({"bodies": {body: {"mass": 1.0, "inertia": {"sphere": 1.0}, "sites": {site: {"position": [0, 0, 0]}}}}})
    assert scene.body_names == (body,)
    for topic in (f"{namespace}/{body}/{site}/imu", f"{namespace}/{body}/impulse", f"{namespace}/{body}/{site}/wrench_marker"):
        assert validate_full_topic_name(topic), topic


@pytest.mark.parametrize(("name", "why"), [
    ("bøx", "a name of ASCII letters"),
    ("1box", "a name of ASCII letters"),
    ("_box", "a name of ASCII letters"),
    ("box\x1b[31m", "a name of ASCII letters"),
    ("world", "a name other than the reserved"),
], ids=["non-ascii", "digit-first", "underscore-first", "escape-code", "reserved"])
def test_names_that_no_ros_topic_can_hold_are_refused(tmp_path: Path, name: str, why: str) -> None:
    path = write(tmp_path, json.dumps({"bodies": {name: {"mass": 1.0, "inertia": {"sphere": 1.0}}}}))
    with pytest.raises(SceneError, match=re.escape(why)) as info:
        load_scene(path)
    assert "\x1b" not in str(info.value)  # shown escaped, never sent raw to a terminal


def test_yaml_11_booleans_are_names(tmp_path: Path) -> None:
    """YAML 1.1 read ``on``/``yes``/``no`` as booleans, so such a body name failed as 'True'."""
    path = write(tmp_path, f"bodies: {{on: {GOOD_BODY}, yes: {GOOD_BODY}, no: {GOOD_BODY}}}\n")
    assert load_scene(path).body_names == ("on", "yes", "no")


# --------------------------------------------------------------------------- YAML 1.2 numbers, README and docs


@pytest.mark.parametrize("spelling", ["1.0e6", "1e6", "1E+6", "1000000", "1.0e+6", "0x10", "+1e6"])
def test_numbers_in_yaml_12_spellings_are_numbers(tmp_path: Path, spelling: str) -> None:
    """Every YAML 1.2 spelling of a number is a number (YAML 1.1, PyYAML's, reads ``1.0e6`` as a string)."""
    path = write(tmp_path, f"energy_growth_limit: {spelling}\nbodies: {{b: {GOOD_BODY}}}\n")
    assert load_scene(path).energy_growth_limit == float(int(spelling, 16) if spelling.startswith("0x") else float(spelling))


def test_quoted_numbers_stay_strings(tmp_path: Path) -> None:
    path = write(tmp_path, f"energy_growth_limit: '1.0e6'\nbodies: {{b: {GOOD_BODY}}}\n")
    with pytest.raises(SceneError, match=re.escape("energy_growth_limit: expected a number") + ".*got '1.0e6'"):
        load_scene(path)


#: A ```yaml block in README.md or docs/*.md preceded by this line is a fragment (not a whole scene).
README_FRAGMENT_MARKER = "<!-- yaml fragment: not a whole scene -->"

#: The pages whose ```yaml blocks are scenes a reader may copy.
DOC_PAGES = [REPO / "README.md", *sorted((REPO / "docs").glob("*.md"))]


def _yaml_blocks(page: Path) -> list[tuple[int, str, bool]]:
    lines = page.read_text(encoding="utf-8").splitlines()
    blocks, i = [], 0
    while i < len(lines):
        if lines[i].strip() == "```yaml":
            start = i
            fragment = any(lines[j].strip() == README_FRAGMENT_MARKER for j in range(max(0, i - 2), i))
            i += 1
            body = []
            while lines[i].strip() != "```":
                body.append(lines[i])
                i += 1
            blocks.append((start + 1, "\n".join(body) + "\n", fragment))
        i += 1
    return blocks


def test_every_yaml_block_in_the_readme_and_docs_loads(tmp_path: Path) -> None:
    blocks = [(page, *block) for page in DOC_PAGES for block in _yaml_blocks(page)]
    assert {page.name for page, *_ in blocks} >= {"README.md", "scenes.md", "robot_stack.md"}, "a scene example is gone"
    for page, line, text, fragment in blocks:
        where = f"{page.relative_to(REPO)} line {line}"
        path = write(tmp_path, text, f"{page.stem}_line_{line}.yaml")
        if fragment:
            from rigid_body_sim.core.scene_yaml import read_yaml

            read_yaml(text)  # a fragment must still be YAML
            continue
        scene = load_scene(path)
        assert scene.body_names, where


# --------------------------------------------------------------------------- scenes that load but cannot run


TINY = scene_module.MIN_POSITIVE


@pytest.mark.parametrize(("text", "key", "expected"), [
    ("bodies: {b: {mass: 5e-324, inertia: {principal: [1, 1, 1]}}}", "bodies.b.mass",
     r"a number ≥ 2.225e-308 \(kg\), a normal float64"),
    ("bodies: {b: {mass: 1, inertia: {principal: [1, 1, 5e-324]}}}", "bodies.b.inertia.principal",
     r"3 numbers ≥ 2.225e-308 .*normal float64s"),
    ("bodies: {b: {mass: 1e-200, inertia: {sphere: 1e-60}}}", "bodies.b.inertia.sphere",
     r"a mass and shape whose principal moments are finite and ≥ 2.225e-308"),
    ("bodies: {b: {mass: 1e200, inertia: {box: [1e100, 1e100, 1e100]}}}", "bodies.b.inertia.box",
     r"a mass and shape whose principal moments are finite"),
    ("bodies: {b: {mass: 1, inertia: {principal: [1e308, 1e308, 1e308]}, twist: {angular: [0, 0, 10]}}}", "bodies.b",
     r"a body whose initial angular momentum \|Iω\| is at most 1e\+154"),
    ("bodies: {b: {mass: 1, inertia: {sphere: 1}, twist: {angular: [0, 0, 1e300]}}}", "bodies.b",
     r"a body whose initial angular velocity \|ω\| is at most 1e\+154"),
    ("energy_growth_limit: 1e300\nbodies: {b: {mass: 1, inertia: {sphere: 1}, twist: {linear: [1e6, 0, 0]}}}", "bodies.b",
     r"a body whose initial kinetic energy .*times energy_growth_limit = 1e\+300"),
    ("bodies: {b: {mass: 1e300, inertia: {sphere: 1}, twist: {linear: [0, 1e10, 0]}}}", "bodies.b",
     r"a body whose initial linear momentum m\|v\| is at most 1e\+154"),
    ("gravity: [0, 0, -9.81]\nbodies: {b: {mass: 1e160, inertia: {sphere: 1}}}", "bodies.b",
     r"a body whose initial weight m\|g\| is at most 1e\+154"),
    ("gravity: [0, 0, -1e150]\nbodies: {b: {mass: 1, inertia: {sphere: 1}, pose: {position: [0, 0, 1e300]}}}", "bodies.b",
     r"a body whose initial gravitational potential m\|g\|\|p\| is finite"),
    ("bodies: {b: {mass: 1e-10, inertia: {sphere: 1}}}\nwrenches: [{body: b, frame: b, force: [1e300, 0, 0]}]",
     "wrenches[0]", r"a wrench whose force, torque about the centre of mass and accelerations of 'b' are at most"),
    ("bodies: {b: {mass: 1, inertia: {sphere: 1}, sites: {s: {position: [1e300, 0, 0]}}}}\n"
     "wrenches: [{body: b, frame: b/s, force: [0, 1e100, 0]}]", "wrenches[0]", r"a wrench whose force, torque"),
], ids=["subnormal-mass", "subnormal-moment", "moments-underflow", "moments-overflow", "huge-moment-with-spin",
        "huge-spin", "energy-times-limit", "huge-momentum", "weight", "potential", "wrench-acceleration", "wrench-lever-arm"])
def test_scenes_that_would_load_but_not_run_are_refused(tmp_path: Path, text: str, key: str, expected: str) -> None:
    """Scenes that would load but not run are refused: a subnormal mass (fails at step 0), a 1e308 moment with
    spin (infinite energy)."""
    path = write(tmp_path, text + "\n")
    with pytest.raises(SceneError, match=re.escape(f"{path}: {key}: expected ") + expected):
        load_scene(path)


EXTREME_SCENES = {
    "tiny": {"bodies": {
        "mote": {"mass": TINY, "inertia": {"principal": [TINY, TINY, 1.5 * TINY]},
                 "twist": {"linear": [1.0, 0.0, 0.0], "angular": [1.0, 1.0, 1.0]}},
        "speck": {"mass": TINY, "inertia": {"sphere": 2.0}, "twist": {"angular": [0.0, 0.0, 1.0]}},
    }},
    "huge": {"gravity": [0.0, 0.0, -9.81], "bodies": {
        "planet": {"mass": 1e150, "inertia": {"principal": [1e150, 1.2e150, 1.5e150]}, "pose": {"position": [1e3, 0, 0]},
                   "twist": {"linear": [1e3, 0.0, 0.0], "angular": [1.0, 2.0, 3.0]}},
        "far": {"mass": 1.0, "inertia": {"sphere": 1.0}, "pose": {"position": [1e300, -1e300, 1e300]}},
    }},
}


@pytest.mark.parametrize("which", list(EXTREME_SCENES))
def test_scenes_at_the_extremes_the_loader_accepts_can_run(which: str) -> None:
    """Whatever loads can be stepped: finite energy and momenta at t = 0, and a step either works
    or reports a blow-up (NonFiniteStateError); never a floating-point warning or another error."""
    from rigid_body_sim.core import INTEGRATORS, NonFiniteStateError

    scene = load_scene(EXTREME_SCENES[which])
    for integrator in sorted(set(INTEGRATORS) - {"reference"}):
        sim = Simulator(scene, integrator, 1e-3)
        assert np.all(np.isfinite(sim.kinetic_energy() + sim.potential_energy()))
        assert np.all(np.isfinite(sim.angular_momentum())) and np.all(np.isfinite(sim.linear_momentum()))
        try:
            sim.step(3)
        except NonFiniteStateError:
            pass
        assert np.all(np.isfinite(sim.positions_world())) and np.all(np.isfinite(sim.angular_velocities_world()))


# --------------------------------------------------------------------------- a careless user's files


@pytest.mark.parametrize(("data", "ok"), [
    (("\ufeff" + f"bodies: {{b: {GOOD_BODY}}}\n").encode("utf-8"), True),
    (f"bodies: {{b: {GOOD_BODY}}}\n".encode("utf-16"), True),  # Notepad's "Unicode": UTF-16 LE with a BOM
    (f"bodies: {{b: {GOOD_BODY}}}\n".encode("utf-16-be"), False),  # no BOM: not UTF-8
    (f"bodies: {{b: {GOOD_BODY}}}\n".encode("utf-32"), True),
    (b"bodies: {b: {mass: 1.0, inertia: {sphere: 0.5}}}\r\n", True),  # Windows line ends
    (b"\x89PNG\r\n\x1a\n\x00\x00\x00\rIHDR" + bytes(range(256)), False),
    (b"bodies:\x00 {}\n", False),
    (b"bodies: {b\xe9: 1}\n", False),  # Latin-1
], ids=["utf8-bom", "utf16-bom", "utf16-no-bom", "utf32-bom", "crlf", "png", "nul", "latin1"])
def test_encodings_and_binary_files(tmp_path: Path, data: bytes, ok: bool) -> None:
    path = write(tmp_path, data)
    if ok:
        assert load_scene(path).body_names == ("b",)
    else:
        with pytest.raises(SceneError, match=re.escape(f"{path}: ")) as info:
            load_scene(path)
        message = str(info.value)
        assert len(message) < 400 and message.isprintable(), message


def test_tabs_get_a_hint(tmp_path: Path) -> None:
    path = write(tmp_path, "bodies:\n\tb: {mass: 1.0, inertia: {sphere: 0.5}}\n")
    with pytest.raises(SceneError, match=re.escape(f"{path}: not valid YAML at line 2") + ".*replace the tabs"):
        load_scene(path)


@pytest.mark.parametrize("text", [
    "!!python/object/apply:os.system ['touch {marker}']\n",
    "bodies: {{b: !!python/object/apply:os.system ['touch {marker}']}}\n",
    "bodies: {{b: {{mass: !!binary aGVsbG8=, inertia: {{sphere: 1}}}}}}\n",
    "bodies: !!set {{b: null}}\n",
    "bodies: !!omap [b: 1]\n",
    "bodies: {{b: {{mass: !mytag 1, inertia: {{sphere: 1}}}}}}\n",
    "bodies: {{b: {{mass: !!timestamp 2001-12-14, inertia: {{sphere: 1}}}}}}\n",
], ids=["python-object-top", "python-object-body", "binary", "set", "omap", "local-tag", "timestamp"])
def test_tags_other_than_the_core_ones_are_refused(tmp_path: Path, text: str) -> None:
    marker = tmp_path / "executed"
    path = write(tmp_path, text.format(marker=marker))
    with pytest.raises(SceneError, match=r"expected a plain (value|mapping|list), got the tag"):
        load_scene(path)
    assert not marker.exists()


def test_core_tags_are_honoured(tmp_path: Path) -> None:
    path = write(tmp_path, "energy_growth_limit: !!float 100\nbodies: {b: {mass: !!int '2', inertia: {sphere: !!float '0.5'}}}\n")
    scene = load_scene(path)
    assert scene.energy_growth_limit == 100.0 and scene.model.mass[0] == 2.0
    with pytest.raises(SceneError, match=re.escape("bodies.b: expected a value of the type its tag")):
        load_scene(write(tmp_path, "bodies: {b: !!int x}\n"))


@pytest.mark.parametrize(("text", "key", "expected"), [
    ("bodies: {b: {mass: [[[[1.0]]]], inertia: {sphere: 1}}}\n", "bodies.b.mass", "a number"),
    ("gravity: [[0], [0], [-9.81]]\nbodies: {b: {mass: 1, inertia: {sphere: 1}}}\n", "gravity", "a list of 3"),
    ("bodies: {b: {mass: 1, inertia: {box: [[1, 1, 1]]}}}\n", "bodies.b.inertia.box", "a list of 3"),
    ("bodies: {b: {mass: 1, inertia: {tensor: [[[1]], [0, 1, 0], [0, 0, 1]]}}}\n", "bodies.b.inertia.tensor[0]", "a list of 3"),
    ("bodies: {b: {mass: 1e999, inertia: {sphere: 1}}}\n", "bodies.b.mass", "a finite number"),
    ("bodies: {b: {mass: .nan, inertia: {sphere: 1}}}\n", "bodies.b.mass", "a finite number"),
    ("bodies: {[a, b]: {mass: 1, inertia: {sphere: 1}}}\n", "bodies", "a name or number as a mapping key"),
    ("bodies: {null: {mass: 1, inertia: {sphere: 1}}}\n", "bodies.None", "a name of ASCII letters"),
    ("bodies: {b: {mass: 1, inertia: {sphere: 1}, sites: {world_aligned: {position: [0, 0, 0]}}}}\n",
     "bodies.b.sites.world_aligned", "a name other than the reserved"),
    ("--- {bodies: {}}\n--- {bodies: {}}\n", "", "expected one YAML document"),
], ids=["nested-mass", "nested-gravity", "nested-box", "nested-tensor", "float-overflow", "nan", "list-key",
        "null-name", "reserved-site", "two-documents"])
def test_careless_values(tmp_path: Path, text: str, key: str, expected: str) -> None:
    path = write(tmp_path, text)
    with pytest.raises(SceneError, match=re.escape(f"{path}: {key + ': ' if key else ''}") + ".*" + re.escape(expected)):
        load_scene(path)


def test_merge_keys_and_anchors_still_work(tmp_path: Path) -> None:
    text = ("bodies:\n  a: &shape {mass: 1.0, inertia: {sphere: 0.5}}\n  b: *shape\n"
            "  c: {<<: *shape, mass: 3.0}\n  d: {<<: [{mass: 4.0}, *shape]}\n")
    scene = load_scene(write(tmp_path, text))
    assert scene.body_names == ("a", "b", "c", "d")
    np.testing.assert_array_equal(scene.model.mass, [1.0, 1.0, 3.0, 4.0])


@pytest.mark.parametrize("text", ["", "\n\n", "# nothing\n", "---\n", "\ufeff"],
                         ids=["empty", "blank", "comment", "document-marker", "bom-only"])
def test_empty_files(tmp_path: Path, text: str) -> None:
    path = write(tmp_path, text)
    with pytest.raises(SceneError, match=re.escape(f"{path}: expected a mapping with key 'bodies' at the top, got nothing")):
        load_scene(path)


# --------------------------------------------------------------------------- large scenes


def test_more_bodies_than_the_limit_are_refused_before_validation() -> None:
    body = {"mass": 1.0, "inertia": {"sphere": 1.0}}
    bodies = {f"b{i}": body for i in range(scene_module.MAX_BODIES + 1)}
    start = time.process_time()
    with pytest.raises(SceneError, match=re.escape(f"<dict>: bodies: expected at most {scene_module.MAX_BODIES:,} bodies, "
                                                   f"got {scene_module.MAX_BODIES + 1:,}")):
        load_scene({"bodies": bodies})
    assert time.process_time() - start < 1.0  # refused by its length, not after validating every body


def _many_bodies_yaml(n: int) -> str:
    lines = ["gravity: [0.0, 0.0, -9.81]", "bodies:"]
    for i in range(n):
        lines.append(f"  b{i}: {{mass: {1.0 + i % 7}, inertia: {{box: [1.0, 0.6, 0.4]}}, pose: {{position: "
                     f"[{i % 100}.0, {i // 100 % 100}.0, {i // 10000}.0], orientation: [0, 0, 0, 1]}}, "
                     f"twist: {{linear: [0, 0, 0], angular: [0.1, 0.2, 0.3]}}, sites: {{tip: {{position: [0.5, 0, 0]}}}}}}")
    return "\n".join(lines) + "\n"


def test_loading_many_bodies_is_linear_and_fast(tmp_path: Path) -> None:
    """10⁴ bodies from a file load in time linear in the bodies (PyYAML's pure-Python parser and per-body
    numpy calls would take ~12 s)."""
    small, large = write(tmp_path, _many_bodies_yaml(1000), "small.yaml"), write(tmp_path, _many_bodies_yaml(10_000), "large.yaml")
    warm_up = write(tmp_path, _many_bodies_yaml(10), "warm_up.yaml")  # first-call costs out of the timings
    times = {}
    for path in (warm_up, small, large):
        start = time.process_time()
        scene = load_scene(path)
        times[path.name] = time.process_time() - start
    assert len(scene.body_names) == 10_000 and scene.model.site_names[-1] == "b9999/tip"
    print(f"load: 1e3 bodies {times['small.yaml']:.3f} s CPU, 1e4 bodies {times['large.yaml']:.3f} s CPU")
    assert times["large.yaml"] < 30 * times["small.yaml"]  # linear (10×), with room for noise; not quadratic
    assert times["large.yaml"] < 6.0  # generous: about 0.3 s seen unloaded


def _compact_bodies_yaml(n: int) -> str:
    """n bodies with a mass, box inertia and position each: about 80 bytes a body, as a swarm is written."""
    lines = ["gravity: [0.0, 0.0, -9.81]", "bodies:"]
    lines += [f"  b{i}: {{mass: {1 + i % 7}, inertia: {{box: [1, 0.6, 0.4]}}, pose: {{position: [{i % 100}, "
              f"{i // 100 % 100}, {i // 10000}]}}}}" for i in range(n)]
    return "\n".join(lines) + "\n"


@pytest.mark.slow
def test_a_scene_at_the_body_limit_loads_in_seconds(tmp_path: Path) -> None:
    """MAX_BODIES bodies in one file within MAX_SCENE_BYTES load in seconds (PyYAML's pure-Python parser
    would take ~100 s)."""
    path = write(tmp_path, _compact_bodies_yaml(scene_module.MAX_BODIES), "limit.yaml")
    assert path.stat().st_size <= scene_module.MAX_SCENE_BYTES
    result = run_measured([sys.executable, "-c", f"from rigid_body_sim.core.scene import load_scene; "
                           f"s = load_scene({str(path)!r}); print(len(s.body_names))"], timeout_s=600)
    print(f"{scene_module.MAX_BODIES} bodies: wall {result.wall_s:.1f} s, cpu {result.cpu_s:.1f} s, "
          f"peak RSS {result.peak_rss_mb:.0f} MB")
    assert result.code == 0, result.stderr[-2000:]
    assert result.stdout.strip() == str(scene_module.MAX_BODIES)
    assert result.cpu_s < 40  # about 7 s seen under load 4; a pure-Python parser takes about 100 s


# --------------------------------------------------------------------------- special files and races


def test_fifo_and_devices_never_block_the_loader(tmp_path: Path) -> None:
    fifo = tmp_path / "scene.fifo"
    os.mkfifo(fifo)
    for path in (fifo, Path("/dev/zero"), Path("/dev/null"), tmp_path):
        start = time.monotonic()
        with pytest.raises(SceneError, match=re.escape(f"{path}: cannot read scene file")):
            load_scene(path)
        assert time.monotonic() - start < 5.0


_FLIP_PROGRAM = textwrap.dedent("""\
    import os, sys
    from rigid_body_sim.core import SceneError, load_scene
    link, regular, fifo = sys.argv[1:4]
    real_stat = os.stat
    def stat_then_flip(path, *args, **kwargs):
        result = real_stat(path, *args, **kwargs)
        if os.fspath(path) == link:  # the race at its worst: right after the check, before the open
            os.unlink(link)
            os.symlink(fifo, link)
        return result
    os.stat = stat_then_flip
    try:
        load_scene(link)
        print("loaded")
    except SceneError as exc:
        print("refused:", exc)
""")


def test_a_path_swapped_to_a_fifo_after_the_check_never_blocks(tmp_path: Path) -> None:
    """A symlink flipped from a file to a FIFO between stat() and open() never blocks load_scene."""
    regular = write(tmp_path, f"bodies: {{b: {GOOD_BODY}}}\n")
    fifo = tmp_path / "scene.fifo"
    os.mkfifo(fifo)
    link = tmp_path / "link.yaml"
    link.symlink_to(regular)
    result = run_measured([sys.executable, "-c", _FLIP_PROGRAM, str(link), str(regular), str(fifo)], timeout_s=30)
    assert result.code == 0, f"load_scene blocked or failed: {result.stderr[-2000:]}"
    assert result.stdout.startswith(("loaded", "refused: ")), result.stdout
    if result.stdout.startswith("refused"):
        assert "not a regular file" in result.stdout


# --------------------------------------------------------------------------- the rigid-body-sim command

SPINNER = ("bodies:\n  plate:\n    mass: 1.0\n    inertia: {principal: [1.0, 2.0, 2.5]}\n"
           "    twist: {angular: [0.1, 2.0, 0.05]}\n")


@pytest.fixture
def spinner(tmp_path: Path) -> Path:
    return write(tmp_path, SPINNER, "spinner.yaml")


def usage_error(capsys: pytest.CaptureFixture[str], argv: list[str]) -> str:
    """Run the command in-process expecting argparse's exit code 2; return stderr."""
    from rigid_body_sim.cli import main

    with pytest.raises(SystemExit) as info:
        main(argv)
    assert info.value.code == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err
    return err


@pytest.mark.parametrize(("extra", "message"), [
    (["--dt", "1e-320"], "argument --dt: expected a step giving at most 2^53 steps over the duration"),
    (["--dt", "1e-300"], "argument --dt: expected a step giving at most 2^53 steps over the duration"),
    (["-T", "1e308"], "argument --dt: expected a step giving at most 2^53 steps over the duration"),
    (["--rate", "1e-320"], "argument --rate: expected a rate giving at least one sample per"),
    (["--rate", "1e-200", "--dt", "1e-200", "-T", "1e-190"], "argument --rate: expected a rate giving at least one"),
], ids=["subnormal-dt", "tiny-dt", "huge-duration", "subnormal-rate", "underflowing-rate"])
def test_steps_and_samples_that_overflow_are_usage_errors(capsys: pytest.CaptureFixture[str], spinner: Path,
                                                          extra: list[str], message: str) -> None:
    """Steps and samples that overflow (``--dt 1e-320``) are usage errors, not tracebacks."""
    argv = ["run", str(spinner), "-T", "1", *extra] if "-T" not in extra else ["run", str(spinner), *extra]
    err = usage_error(capsys, argv)
    assert message in err, err


@pytest.mark.parametrize("option", ["--csv", "--record"])
@pytest.mark.parametrize("target", ["/dev/full", "/dev/null", "fifo", "directory", "/proc/rbs_hostile_test.out"])
def test_unusable_outputs_are_usage_errors_without_a_traceback(capsys: pytest.CaptureFixture[str], tmp_path: Path,
                                                               spinner: Path, option: str, target: str) -> None:
    """``--csv /dev/full`` and unwritable paths are usage errors without a traceback (also as root).
    In-process (argparse's exit 2); ``--record /dev/full`` also as its own process, the exit status
    and stderr a shell sees."""
    if target == "fifo":
        target = str(tmp_path / "out.fifo")
        os.mkfifo(target)
    elif target == "directory":
        target = str(tmp_path)
    argv = ["run", str(spinner), "-T", "0.05", option, target]
    err = usage_error(capsys, argv)
    assert f"rigid-body-sim run: error: argument {option}: " in err, err
    if (target, option) == ("/dev/full", "--record"):
        result = run_measured(cli(*argv), timeout_s=60)
        assert result.code == 2, (result.code, result.stderr[-2000:])
        assert "Traceback" not in result.stderr
        assert f"rigid-body-sim run: error: argument {option}: " in result.stderr, result.stderr


_FSIZE_PROGRAM = textwrap.dedent("""\
    import resource, signal, sys
    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # a write past the limit then fails with EFBIG, as on a full disk
    resource.setrlimit(resource.RLIMIT_FSIZE, (20_000, 20_000))
    from rigid_body_sim.cli import main
    sys.exit(main(sys.argv[1:]))
""")


@pytest.mark.parametrize("option", ["--csv", "--record"])
def test_a_write_failing_midway_is_a_clear_error(tmp_path: Path, spinner: Path, option: str) -> None:
    """A full disk in the middle of a run: exit 1 naming the file, no traceback, the other files closed."""
    out = tmp_path / ("out.csv" if option == "--csv" else "out.mcap")
    other = ["--record", str(tmp_path / "other.mcap")] if option == "--csv" else ["--csv", str(tmp_path / "other.csv")]
    result = run_measured([sys.executable, "-c", _FSIZE_PROGRAM, "run", str(spinner), "-T", "20", "--dt", "0.001",
                           "--rate", "1000", option, str(out)], timeout_s=120)
    assert result.code == 1, (result.code, result.stderr[-2000:])
    assert "Traceback" not in result.stderr
    assert f"cannot write {out}" in result.stderr, result.stderr
    del other


@pytest.mark.parametrize("how", ["same-path", "symlink", "hard-link", "scene"])
def test_outputs_that_are_one_file_are_refused(capsys: pytest.CaptureFixture[str], tmp_path: Path, spinner: Path,
                                               how: str) -> None:
    """``--csv`` and ``--record`` naming one file (directly or through a link) are refused."""
    csv = tmp_path / "out.csv"
    record = csv
    if how == "symlink":
        record = tmp_path / "link.mcap"
        record.symlink_to(csv)
    elif how == "hard-link":
        csv.write_text("old\n")
        record = tmp_path / "hard.mcap"
        os.link(csv, record)
    elif how == "scene":
        record = spinner
    before = spinner.read_bytes()
    err = usage_error(capsys, ["run", str(spinner), "-T", "0.05", "--csv", str(csv), "--record", str(record)])
    assert "argument --record: " in err and ("the same file as --csv" in err or "the scene file" in err), err
    assert spinner.read_bytes() == before


def test_plot_output_that_is_the_run_is_refused(capsys: pytest.CaptureFixture[str], tmp_path: Path,
                                                spinner: Path) -> None:
    from rigid_body_sim.cli import main

    run = tmp_path / "run.csv"
    assert main(["run", str(spinner), "-T", "0.05", "--csv", str(run), "-q"]) == 0
    before = run.read_bytes()
    err = usage_error(capsys, ["plot", str(run), "-o", str(run)])
    assert "argument --output: " in err and "the run file itself" in err
    assert run.read_bytes() == before


@pytest.mark.parametrize(("sig", "code"), [pytest.param(signal.SIGTERM, 0, marks=pytest.mark.slow), (signal.SIGINT, 0)],
                         ids=["SIGTERM", "SIGINT"])  # one handler (rigid_body_sim.signals) for both; SIGTERM in test-slow
def test_a_signal_during_run_closes_and_marks_the_files(tmp_path: Path, spinner: Path, sig: int, code: int) -> None:
    """A signal during ``run`` closes the files: the CSV and the MCAP file both say the run was interrupted
    (by which signal, at what t), and ``plot`` reads both."""
    from rigid_body_sim.cli import main
    from rigid_body_sim.offline.csv_io import read_csv
    from rigid_body_sim.offline.recording import read_recording

    csv, record = tmp_path / "run.csv", tmp_path / "run.mcap"
    proc = subprocess.Popen(cli("run", str(spinner), "-T", "100000", "--dt", "1e-4", "--csv", str(csv), "--record",
                                str(record)), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 60
        while not (csv.exists() and csv.stat().st_size > 20_000):
            assert proc.poll() is None and time.monotonic() < deadline, "the run did not start writing"
            time.sleep(0.05)
        proc.send_signal(sig)
        out, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == code, err
    assert "Traceback" not in err
    assert f"rigid-body-sim run: interrupted by {signal.Signals(sig).name}" in err
    data = read_csv(csv)
    assert data.meta["status"].startswith(f"interrupted by {signal.Signals(sig).name} at t = ")
    recording, _ = read_recording(record)
    assert recording.meta["status"] == data.meta["status"]
    assert len(recording.time) >= 1 and len(data.time) >= 1
    assert main(["plot", str(record), "-o", str(tmp_path / "from_mcap.png")]) == 0
    assert main(["plot", str(csv), "-o", str(tmp_path / "from_csv.png")]) == 0


def test_a_complete_run_says_so(tmp_path: Path, spinner: Path) -> None:
    from rigid_body_sim.cli import main
    from rigid_body_sim.offline.csv_io import read_csv
    from rigid_body_sim.offline.recording import read_recording

    csv, record = tmp_path / "run.csv", tmp_path / "run.mcap"
    assert main(["run", str(spinner), "-T", "0.1", "--csv", str(csv), "--record", str(record), "-q"]) == 0
    assert read_csv(csv).meta["status"] == "complete: 10 steps, t = 0.1 s"
    assert read_recording(record)[0].meta["status"] == "complete: 10 steps, t = 0.1 s"


@pytest.mark.parametrize("target", ["/dev/zero", "/dev/urandom", "fifo", "sparse", "long-line"])
def test_plot_of_special_and_huge_files_is_refused_in_bounded_memory(tmp_path: Path, target: str) -> None:
    """``rigid-body-sim plot`` of special and huge files (``/dev/zero``, a FIFO, a sparse file) is refused in
    bounded memory."""
    if target == "fifo":
        target = str(tmp_path / "run.fifo")
        os.mkfifo(target)
    elif target == "sparse":  # 4 GiB of nothing on disk
        target = str(tmp_path / "sparse.csv")
        with open(target, "wb") as f:
            f.truncate(4 << 30)
    elif target == "long-line":  # 100 MiB without a newline, under the size limit
        target = str(tmp_path / "long.csv")
        with open(target, "wb") as f:
            f.truncate(100 << 20)
    result = run_measured(cli("plot", target), timeout_s=60)
    print(f"plot {target}: exit {result.code}, wall {result.wall_s:.2f} s, peak RSS {result.peak_rss_mb:.0f} MB")
    assert result.code == 1, (result.code, result.stderr[-2000:])
    assert "Traceback" not in result.stderr
    assert result.peak_rss_mb < 400


def test_check_imports_only_the_loader(tmp_path: Path, spinner: Path) -> None:
    """``check`` needs the loader only: no numba, no simulator (fast, small: the alias-bomb bound)."""
    program = ("import json, sys\nfrom rigid_body_sim.cli import main\ncode = main(['check', sys.argv[1]])\n"
               "print(json.dumps([code, sorted(m for m in ('numba', 'scipy', 'rigid_body_sim.core.simulator', "
               "'matplotlib', 'mcap') if m in sys.modules)]))")
    result = run_measured([sys.executable, "-c", program, str(spinner)], timeout_s=60)
    assert result.code == 0, result.stderr[-2000:]
    code, loaded = json.loads(result.stdout.strip().splitlines()[-1])
    print(f"check: wall {result.wall_s:.2f} s, cpu {result.cpu_s:.2f} s, peak RSS {result.peak_rss_mb:.0f} MB")
    assert code == 0 and loaded == []
    assert result.peak_rss_mb < 100


# --------------------------------------------------------------------------- what the node's record_path gets


@pytest.mark.parametrize("target", ["fifo", "fifo-with-reader", "/dev/full", "directory"])
def test_the_recorder_never_blocks_on_a_special_file(tmp_path: Path, target: str) -> None:
    """``record_path:=`` a FIFO (an open for writing would block under the tick lock) never blocks:
    McapRecorder, which the node uses, refuses at once and writes nothing into it."""
    from rigid_body_sim.offline.recording import McapRecorder, check_record_path
    from rigid_body_sim.safe_open import NotRegularFileError

    reader = None
    if target.startswith("fifo"):
        path = tmp_path / "rec.fifo"
        os.mkfifo(path)
        if target == "fifo-with-reader":
            reader = os.open(path, os.O_RDONLY | os.O_NONBLOCK)
    elif target == "directory":
        path = tmp_path
    else:
        path = Path(target)
    try:
        assert check_record_path(path) is not None
        start = time.monotonic()
        with pytest.raises(NotRegularFileError, match="not a regular file"):
            McapRecorder(path)
        assert time.monotonic() - start < 5.0
        if reader is not None:
            assert os.read(reader, 100) == b""  # nothing was written into the FIFO
    finally:
        if reader is not None:
            os.close(reader)


def test_a_path_swapped_to_a_fifo_after_the_check_never_blocks_the_recorder(tmp_path: Path) -> None:
    """check_record_path passes, then the path becomes a FIFO: the open itself refuses it at once."""
    from rigid_body_sim.offline.recording import McapRecorder, check_record_path
    from rigid_body_sim.safe_open import NotRegularFileError

    path = tmp_path / "rec.mcap"
    assert check_record_path(path) is None
    os.mkfifo(path)  # after the check, before the open
    program = textwrap.dedent(f"""\
        from rigid_body_sim.offline.recording import McapRecorder
        from rigid_body_sim.safe_open import NotRegularFileError
        import os
        real_stat = os.stat
        def stat_says_missing(p, *a, **k):  # the race at its worst: the pre-open check saw no file
            if os.fspath(p) == {str(path)!r}:
                raise FileNotFoundError(2, "No such file or directory", p)
            return real_stat(p, *a, **k)
        os.stat = stat_says_missing
        try:
            McapRecorder({str(path)!r})
        except NotRegularFileError as exc:
            print("refused:", exc)
    """)
    result = run_measured([sys.executable, "-c", program], timeout_s=30)
    assert result.code == 0 and result.stdout.startswith("refused:"), (result.code, result.stdout, result.stderr[-2000:])
    del McapRecorder, NotRegularFileError


# --------------------------------------------------------------------------- more careless input


def test_a_path_with_a_nul_character_is_a_scene_error() -> None:
    """A parameter string can hold a NUL; os.open raises ValueError for it, which must not escape."""
    with pytest.raises(SceneError, match=r"cannot read scene file \(the path contains a NUL character\)"):
        load_scene("config/default\x00scene.yaml")


def test_a_huge_unknown_key_gives_a_short_message(tmp_path: Path) -> None:
    path = write(tmp_path, "? " + "k" * 1_000_000 + f"\n: 1\nbodies: {{b: {GOOD_BODY}}}\n")  # an explicit key: no length limit
    with pytest.raises(SceneError, match=re.escape(f"{path}: {'k' * 64}...(1000000 characters): expected one of the keys")) as info:
        load_scene(path)
    assert len(str(info.value)) < 400


@pytest.mark.parametrize("newline", ["\r", "\r\n", "\n"], ids=["cr", "crlf", "lf"])
def test_any_line_ending(tmp_path: Path, newline: str) -> None:
    text = newline.join(["bodies:", "  b:", "    mass: 1.0", "    inertia: {sphere: 0.5}", ""])
    path = tmp_path / "scene.yaml"
    path.write_bytes(text.encode())
    assert load_scene(path).body_names == ("b",)


def test_output_into_a_closed_pipe_is_not_a_traceback(tmp_path: Path) -> None:
    """``rigid-body-sim describe big.yaml | head -1``: the reader goes away; no BrokenPipeError traceback."""
    path = write(tmp_path, _compact_bodies_yaml(3000), "many.yaml")
    with subprocess.Popen(cli("describe", str(path)), stdout=subprocess.PIPE, stderr=subprocess.PIPE) as proc:
        assert proc.stdout is not None and proc.stderr is not None
        proc.stdout.readline()
        proc.stdout.close()  # like head -1
        err = proc.stderr.read().decode()
        proc.wait(timeout=120)
    assert "Traceback" not in err and "BrokenPipeError" not in err, err
    assert proc.returncode == 0  # the reader went away: a stop, not a failure


def test_control_characters_in_a_path_are_escaped_in_messages(tmp_path: Path) -> None:
    path = tmp_path / "red\x1b[31m.yaml"
    with pytest.raises(SceneError) as info:
        load_scene(path)
    assert "\x1b" not in str(info.value) and "red\\x1b[31m.yaml: cannot read scene file" in str(info.value)


@pytest.mark.parametrize("integrator", ["euler", "semi_implicit_euler", "implicit_gyroscopic", "splitting",
                                        "symmetric_splitting", "rk4", "exact_rotor_splitting"])
@pytest.mark.parametrize("twist", [{"linear": [1e50, 0.0, 0.0]}, {"angular": [1e50, 0.0, 1e40]},
                                   {"linear": [1e150, 1e150, 0.0], "angular": [1e150, 1.0, 1.0]}],
                         ids=["v-1e50", "w-1e50", "v-w-1e150"])
def test_huge_twists_step_or_stop_loudly_never_crash(integrator: str, twist: dict) -> None:
    """A 1e50 m/s twist (a division by zero inside the compiled step would kill the node's tick
    thread): every integrator either steps it to a finite state or raises NonFiniteStateError
    (a DivergenceError is one) and leaves the last finite state."""
    from rigid_body_sim.core.simulator import NonFiniteStateError

    scene = load_scene({"bodies": {"b": {"mass": 1.0, "inertia": {"box": [1.0, 0.6, 0.4]}, "twist": twist}}})
    sim = Simulator(scene, integrator, 0.01)
    try:
        sim.step(10)
    except NonFiniteStateError:
        pass
    state = sim.body_state("b")
    for value in (state.position_world, state.orientation_xyzw, state.linear_velocity_world,
                  state.angular_velocity_world):
        assert np.all(np.isfinite(value))
    assert sim.step_count <= 10
