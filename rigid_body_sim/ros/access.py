"""Who can reach the node over DDS: the discovery range, and ROS security when it is asked for.

:func:`prepare_access` runs first thing in ``rigid_body_sim_node``'s ``main``, before the node's
``rclpy.init``:

- **Discovery range.** Unless the environment sets ``ROS_AUTOMATIC_DISCOVERY_RANGE``, it is set
  to ``LOCALHOST`` in this process, so the node is found only by peers on the same host (rcl
  reads this variable; this rcl ignores the older ``ROS_LOCALHOST_ONLY``). ``SUBNET`` has to be
  asked for. The range in use, and where it came from, is the first INFO line of the log.
- **ROS security** (``ROS_SECURITY_ENABLE=true``, ``ROS_SECURITY_KEYSTORE``,
  ``ROS_SECURITY_STRATEGY``): the middleware is tried once, on a private context with the
  node's own arguments (so its enclave), before anything else is built. If it cannot give what
  was asked (the Fast DDS of the PyPI wheels has no security libraries; a keystore that does not
  exist under ``Enforce``), the reason is said in one line and the exit status is 2, as for any
  bad start-up setting, instead of a traceback from inside the node's constructor.

- **Names.** A namespace and node name (``-r __ns:=`` / ``-r __node:=``) so long that the node's
  own services would exceed ROS's name length are refused in one line, exit 2 (rclpy would
  raise inside the node's constructor). The namespace's own limit, for topics
  ``<namespace>/<body>/<site>/imu``, is checked with the parameters (parameters.py).

Only the standard library is imported at module level (``main`` imports this before rclpy).
docs/security.md says what a peer on the domain can do and how to confine it.
"""

from __future__ import annotations

import os
import sys
import warnings

__all__ = ["prepare_access", "DISCOVERY_RANGES", "DEFAULT_DISCOVERY_RANGE", "MAX_TOPIC_NAME_LENGTH"]

#: Values rcl takes for ROS_AUTOMATIC_DISCOVERY_RANGE.
DISCOVERY_RANGES = ("SUBNET", "LOCALHOST", "OFF", "SYSTEM_DEFAULT")
#: The node's range when the environment does not set one.
DEFAULT_DISCOVERY_RANGE = "LOCALHOST"
#: Exit status for an access setting the node cannot honour (as for bad start-up parameters).
EXIT_BAD_SETTING = 2

_RANGE_VAR = "ROS_AUTOMATIC_DISCOVERY_RANGE"


def _say(message: str) -> None:
    print(f"rigid_body_sim_node: {message}", file=sys.stderr, flush=True)


def _info(message: str) -> None:
    """An INFO line of the ROS log (rcutils' format, like the node's own start-up lines)."""
    from rclpy.logging import get_logger

    get_logger("rigid_body_sim_node").info(message)


def prepare_access(args: list[str] | None = None) -> int | None:
    """Set the discovery range if unset and check ROS security; return None to go on, or the exit
    status (2) after saying in one line why the node cannot start.

    Parameters
    ----------
    args : list of str, optional
        The node's command line (``rclpy.init``'s ``args``; default ``sys.argv``), for the
        security enclave.
    """
    given = os.environ.get(_RANGE_VAR, "")
    if not given:
        os.environ[_RANGE_VAR] = DEFAULT_DISCOVERY_RANGE
        _info(f"discovery range {DEFAULT_DISCOVERY_RANGE}: only peers on this host find the node "
             f"(the node's default; set {_RANGE_VAR}=SUBNET to be found from the network)")
    elif given.upper() not in DISCOVERY_RANGES:
        _say(f"{_RANGE_VAR}={given!r} is not one of {list(DISCOVERY_RANGES)}; not starting")
        return EXIT_BAD_SETTING
    else:
        _info(f"discovery range {given.upper()} (from {_RANGE_VAR})")
    too_long = _service_name_problem(sys.argv[1:] if args is None else args)
    if too_long is not None:
        _say(too_long)
        return EXIT_BAD_SETTING
    if os.environ.get("ROS_SECURITY_ENABLE", "").lower() != "true":
        return None
    reason = _security_problem(args)
    if reason is None:
        return None
    strategy = os.environ.get("ROS_SECURITY_STRATEGY", "Permissive")
    _say(f"ROS security is requested (ROS_SECURITY_ENABLE=true, ROS_SECURITY_STRATEGY={strategy}) but cannot be "
         f"used: {reason}; not starting (see docs/security.md)")
    return EXIT_BAD_SETTING


#: Longest ROS topic or service name (rmw: 255 less the 8 characters of DDS prefixes and suffixes).
MAX_TOPIC_NAME_LENGTH = 247
#: The node's longest own service suffix (rclpy's parameter services).
_LONGEST_SERVICE = "/set_parameters_atomically"
_NODE_NAME = "rigid_body_sim"


def _remapped(args: list[str]) -> tuple[str, str]:
    """The namespace and node name that the command line's ``--ros-args -r __ns:=... -r __node:=...``
    give this node (rcl's rules: the last remap wins; ``name:`` prefixes apply to that node only)."""
    namespace, name = "/", _NODE_NAME
    in_ros_args = False
    rules = []
    for k, arg in enumerate(args):
        if arg == "--ros-args":
            in_ros_args = True
        elif arg == "--":
            in_ros_args = False
        elif in_ros_args and arg in ("-r", "--remap") and k + 1 < len(args):
            rules.append(args[k + 1])
    for rule in rules:
        target, _, value = rule.partition(":=")
        node, _, key = target.rpartition(":")
        if node and node != _NODE_NAME:
            continue
        if key == "__ns":
            namespace = value if value.startswith("/") else "/" + value
        elif key in ("__node", "__name"):
            name = value
    return namespace, name


def _service_name_problem(args: list[str]) -> str | None:
    """Why the node's own services would get names too long for ROS (rclpy would raise inside the
    node's constructor), or None."""
    namespace, name = _remapped(args)
    full = namespace.rstrip("/") + "/" + name
    if len(full) + len(_LONGEST_SERVICE) > MAX_TOPIC_NAME_LENGTH:
        return (f"node name {full!r} has {len(full)} characters with its namespace; at most "
                f"{MAX_TOPIC_NAME_LENGTH - len(_LONGEST_SERVICE)} (MAX_TOPIC_NAME_LENGTH {MAX_TOPIC_NAME_LENGTH} less "
                f"its longest service name {_LONGEST_SERVICE!r}); not starting")
    return None


def _security_problem(args: list[str] | None) -> str | None:
    """Try the middleware with security on a private context: None if a node can be made, else why not."""
    import rclpy
    from rclpy.context import Context
    from rclpy.signals import SignalHandlerOptions

    context = Context()
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # rclpy's "Failed to fini rosout publisher" after the failure
            rclpy.init(args=args, context=context, signal_handler_options=SignalHandlerOptions.NO)
            node = rclpy.create_node("rigid_body_sim_security_probe", context=context,
                                     enable_rosout=False, start_parameter_services=False)
            node.destroy_node()
    except Exception as exc:  # noqa: BLE001  (rclpy's RCLError: whatever rcl or the rmw refused)
        return _first_line(str(exc))
    finally:
        context.try_shutdown()
    return None


def _first_line(text: str) -> str:
    """rcl's message without its source locations: ``error creating node: X, at file.cpp:406, at ...`` → X."""
    line = text.strip().splitlines()[0] if text.strip() else "unknown error"
    line = line.split(", at /")[0].rstrip(".")
    for prefix in ("error creating node: ", "failed to initialize rcl: "):
        line = line.removeprefix(prefix)
    if "doesn't have the security libraries" in line:
        line += " (the Fast DDS of the ros-fastdds wheels is built without -DSECURITY=ON)"
    return line
