"""A start-up signal that lands where Python drops exceptions still stops start-up, silently.

During start-up the node's entry point turns SIGINT/SIGTERM into KeyboardInterrupt
(rigid_body_sim.ros.main._Signals). Raised inside a finalizer, a weakref or gc callback or a
ctypes callback, that exception would be printed as "Exception ignored ... Traceback" and
dropped, and start-up would go on. Each case here runs in its own process: it installs the
entry point's handlers, enters such a place and spins there for SPIN_S; this test sends the real
signal once it is inside. The process must then stop with KeyboardInterrupt in ordinary code
right after it leaves that place, and print no traceback. Inside an rclpy call (a half-done
call would break the tear-down) the KeyboardInterrupt must come once the call has returned. A library that turns the
KeyboardInterrupt into its own error, with or without a chain (seen: ``ImportError:
initialization failed`` from scipy's highspy extension), still counts as the stop.
"""

from __future__ import annotations

import signal
import subprocess
import sys
import textwrap
import time

import pytest

SPIN_S = 1.0

PRELUDE = textwrap.dedent(f"""
    import ctypes, ctypes.util, gc, sys, time, weakref
    from rigid_body_sim.ros import main as entry

    left_at = None

    def spin():
        global left_at
        print("inside", flush=True)
        deadline = time.monotonic() + {SPIN_S}
        try:
            while time.monotonic() < deadline:
                pass
        finally:  # also when interrupted there (then dropped and sent again, or passed on)
            left_at = time.monotonic()

    signals = entry._Signals()
""")

CASES = {
    # a ctypes callback that is not llvmlite's: libc's qsort calling a Python comparator
    "ctypes callback": """
        libc = ctypes.CDLL(ctypes.util.find_library("c"))
        compare = ctypes.CFUNCTYPE(ctypes.c_int, ctypes.c_void_p, ctypes.c_void_p)(lambda a, b: spin() or 0)
        values = (ctypes.c_int * 2)(2, 1)
        libc.qsort(values, 2, ctypes.sizeof(ctypes.c_int), compare)
    """,
    # a function called by a finalizer
    "finalizer": """
        class Held:
            def __del__(self):
                spin()
        held = Held()
        del held
    """,
    "weakref callback": """
        class Target:
            pass
        target = Target()
        finalizer = weakref.finalize(target, spin)
        del target
    """,
    # an extension module's initialization calling Python: _pickle imports _compat_pickle (shadowed
    # here by one that spins, then runs the real one)
    "extension module initialization": """
        import os, sysconfig, tempfile
        shadow = tempfile.mkdtemp()
        real = os.path.join(sysconfig.get_paths()["stdlib"], "_compat_pickle.py")
        with open(os.path.join(shadow, "_compat_pickle.py"), "w") as f:
            f.write(chr(10).join(["from __main__ import spin", "spin()", open(real).read()]))
        sys.path.insert(0, shadow)
        import _pickle
        assert _pickle.loads(_pickle.dumps([1])) == [1]
    """,
    "gc callback": """
        def on_collect(phase, info):
            if phase == "start":
                gc.callbacks.remove(on_collect)
                spin()
        gc.callbacks.append(on_collect)
        gc.collect()
    """,
}

# after the place: ordinary code for up to 5 s (inside the same try as the place)
AFTER = textwrap.dedent("""
    while time.monotonic() < left_at + 5.0:
        time.sleep(0.001)
    print("not stopped", flush=True)
""")

STOPPED = textwrap.dedent("""
    except KeyboardInterrupt:
        print(f"stopped in ordinary code {time.monotonic() - (left_at or float('nan')):.3f} s after leaving", flush=True)
""")


def in_try(body: str) -> str:
    """``body`` then AFTER inside ``try:``, with STOPPED as its handler."""
    return "try:\n" + textwrap.indent(textwrap.dedent(body) + AFTER, "    ") + STOPPED


def signal_once_inside(script: str, signum: signal.Signals, timeout: float, *,
                       first_lines: tuple[str, ...] = ()) -> tuple[int, str, str]:
    """Run ``script`` in its own Python; after it prints ``first_lines`` then "inside", send
    ``signum`` 0.1 s later (well inside the spin). Returns (exit status, stdout after "inside", stderr)."""
    process = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        for line in (*first_lines, "inside"):
            assert process.stdout.readline().strip() == line, process.stderr.read()
        time.sleep(0.1)
        process.send_signal(signum)
        out, err = process.communicate(timeout=timeout)
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()
    return process.returncode, out, err


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM], ids=["SIGINT", "SIGTERM"])
@pytest.mark.parametrize("case", list(CASES))
def test_a_start_up_signal_where_exceptions_are_dropped_stops_in_ordinary_code(case, signum):
    returncode, out, err = signal_once_inside(PRELUDE + in_try(CASES[case]), signum, timeout=20)
    assert returncode == 0, err
    assert "Traceback" not in err and "Exception ignored" not in err, err
    lines = out.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("stopped in ordinary code"), out + err
    after_s = float(lines[0].split()[4])
    assert after_s < 1.0, out  # sent again every 20 ms (or raised on return): it lands once the spin is over


REPLACED = PRELUDE.replace("signals = entry._Signals()", "") + textwrap.dedent("""
    signals = entry._Signals()
    print("before the signal", signals.stopped_by(ValueError("bad scene")), flush=True)
    try:
        failed = False
        try:
            spin()
        except KeyboardInterrupt:  # replaced without a chain, as numba's _dispatcher does
            failed = True
        if failed:
            raise ImportError("numba._devicearray failed to import")
    except BaseException as exc:
        print("after the signal", type(exc).__name__, exc.__context__, signals.stopped_by(exc), flush=True)
""")


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM], ids=["SIGINT", "SIGTERM"])
def test_a_start_up_signal_a_library_turned_into_its_own_error_still_counts_as_the_stop(signum):
    """Once a start-up signal has raised its KeyboardInterrupt, any error start-up ends with counts
    as the stop (``_Signals.stopped_by``: the entry point returns 0); before, an error is an error."""
    returncode, out, err = signal_once_inside(REPLACED, signum, timeout=20, first_lines=("before the signal False",))
    assert returncode == 0 and not err, err
    assert out.splitlines() == ["after the signal ImportError None True"], out


HALF_REGISTERED = PRELUDE + textwrap.dedent("""
    import rclpy
    from rclpy.context import Context
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.node import Node
    from rclpy.signals import SignalHandlerOptions
    from std_msgs.msg import Empty

    armed = False

    class SpinningWake(SingleThreadedExecutor):
        def wake(self):
            global armed
            if armed:  # rclpy's create_subscription has listed the subscription, not yet its event handlers
                armed = False
                spin()
            super().wake()

    context = Context()
    rclpy.init(context=context, signal_handler_options=SignalHandlerOptions.NO)
    executor = SpinningWake(context=context)
    node = Node("half_registered", context=context)
    executor.add_node(node)

    def outer_trace(frame, event, arg):  # a debugger's or coverage's, say: put back after the raise
        return None

    sys.settrace(outer_trace)
""") + in_try("""
    armed = True
    node.create_subscription(Empty, "half_registered_topic", lambda _msg: None, 10)
""") + textwrap.dedent("""
    signals.ignore()  # what the entry point does first when start-up ends
    print("trace put back", sys.gettrace() is outer_trace, flush=True)
    executor.shutdown()
    node.destroy_node()
    context.try_shutdown()
    print("destroyed", flush=True)
""")


@pytest.mark.ros
def test_a_start_up_signal_inside_an_rclpy_call_lands_after_it():
    """A signal while rclpy registers a subscription (its call into the executor's wake) is raised
    once that call has returned: the node is then whole, and destroy_node succeeds."""
    returncode, out, err = signal_once_inside(HALF_REGISTERED, signal.SIGINT, timeout=30)
    assert returncode == 0 and "Traceback" not in err, err
    lines = out.strip().splitlines()
    assert len(lines) == 3 and lines[0].startswith("stopped in ordinary code"), out + err
    assert lines[1:] == ["trace put back True", "destroyed"], out + err
    assert float(lines[0].split()[4]) < 1.0, out


def test_a_half_built_node_that_will_not_tear_down_exits_0_saying_why():
    """After a signal cut start-up short, a failing tear-down (what an interrupted rclpy call
    could leave) ends the process with status 0 and one line naming the error, no traceback."""
    script = textwrap.dedent("""
        from rigid_body_sim.ros import main as entry

        class HalfBuilt:
            def destroy_node(self):
                raise ValueError("list.remove(x): x not in list")

        entry._tear_down_half_built(None, HalfBuilt(), None)
        print("not reached")
    """)
    result = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=60)
    assert result.returncode == 0 and result.stdout == "", result.stdout + result.stderr
    assert result.stderr.splitlines() == [
        "rigid_body_sim_node: stopped during start-up; destroying what was built failed "
        "(ValueError('list.remove(x): x not in list')), exiting without it"], result.stderr


CUT_AFTER_RCLPY_NODE = PRELUDE + textwrap.dedent("""
    import rclpy
    from rclpy.context import Context
    from rclpy.signals import SignalHandlerOptions
    from rigid_body_sim.ros.node import RigidBodySimNode

    class SpinningContext(Context):
        def track_node(self, node):  # called by rclpy's Node constructor
            spin()
            super().track_node(node)

    context = SpinningContext()
    rclpy.init(context=context, signal_handler_options=SignalHandlerOptions.NO)
    try:
        RigidBodySimNode(context=context, start_ticking=False)
        print("built", flush=True)
    except KeyboardInterrupt:
        print("stopped in the constructor", flush=True)
        context.try_shutdown()  # destroys every node it tracks, this half-built one too
        print("context shut down", flush=True)
""")


@pytest.mark.ros
def test_a_node_cut_short_right_after_rclpy_built_it_is_destroyed_cleanly():
    """A signal during rclpy's Node constructor is raised in RigidBodySimNode's constructor right
    after it, before any of the node's own attributes exist; rclpy's Context.shutdown then
    destroys that half-built node, which must work (it failed with AttributeError '_tick_loop')."""
    returncode, out, err = signal_once_inside(CUT_AFTER_RCLPY_NODE, signal.SIGTERM, timeout=30)
    assert returncode == 0 and not err, err
    assert out.splitlines() == ["stopped in the constructor", "context shut down"], out + err
