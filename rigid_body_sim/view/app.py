"""``rigid-body-sim view``: serve the live view of a running rigid_body_sim node, or a recording's replay.

:func:`start_server` opens the viser server (saying so in one line when the address is in use),
:func:`run_view` joins the ROS domain as a client of the node (:class:`.client.RosClient`) and
refreshes the page (:class:`.page.LivePage`) until stopped. The replay (:mod:`.replay`) shares
:func:`start_server` and the drawing (:mod:`.drawing`).
"""

from __future__ import annotations

import errno
import socket
import sys
import threading
from typing import Any

from .drawing import Bodies, _Shape, setup_scene, shape_from_marker
from .page import REFRESH_HZ

__all__ = ["run_view", "port_in_use", "Bodies", "shape_from_marker", "setup_scene", "start_server", "REFRESH_HZ",
           "PROG", "_Shape"]

PROG = "rigid-body-sim view"
#: The body the "Feel the offset" panel strikes (the default scene's box) unless told otherwise.
DEFAULT_STRIKE_BODY = "box"


def port_in_use(host: str, port: int) -> str | None:
    """Why ``host:port`` cannot be listened on (a one-line reason), or None if it can."""
    with socket.socket(socket.AF_INET6 if ":" in host else socket.AF_INET, socket.SOCK_STREAM) as probe:
        probe.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)  # as the server's own socket
        try:
            probe.bind((host, port))
        except OSError as exc:
            if exc.errno == errno.EADDRINUSE:
                return f"address {host}:{port} is already in use (another view or server?); choose another with --port"
            return f"cannot listen on {host}:{port}: {exc.strerror or exc}"
    return None


def start_server(host: str, port: int) -> Any:
    """A viser server on ``host:port``, or None after saying why not (the address in use) on stderr."""
    problem = port_in_use(host, port)
    if problem:
        print(f"{PROG}: {problem}", file=sys.stderr)
        return None
    import viser

    server = viser.ViserServer(host=host, port=port, verbose=False)
    if server.get_port() != port:  # viser moves to the next free port; we promised this one
        server.stop()
        print(f"{PROG}: address {host}:{port} is already in use; choose another with --port", file=sys.stderr)
        return None
    return server


def shown_host(host: str) -> str:
    return "localhost" if host in ("127.0.0.1", "0.0.0.0", "::", "::1") else host


def run_view(namespace: str, node_name: str, host: str, port: int, strike_body: str, stop: threading.Event) -> int:
    """Serve the view until ``stop`` is set; returns the exit code (2: the address is in use)."""
    server = start_server(host, port)
    if server is None:
        return 2
    from .client import RosClient
    from .page import LivePage

    ros = RosClient(namespace, node_name, strike_body)
    try:
        page = LivePage(server, ros)
        print(f"{PROG}: open http://{shown_host(host)}:{port} (simulator {ros.sim_name}); Ctrl-C stops", flush=True)
        waiting_said = False
        while not stop.wait(1.0 / REFRESH_HZ):
            page.refresh()
            if not ros.node_seen() and not waiting_said:
                print(f"{PROG}: waiting for a rigid_body_sim node (nothing publishes {ros.poses_topic} yet)", flush=True)
                waiting_said = True
            elif ros.node_seen():
                waiting_said = False
        return 0
    finally:
        ros.close()
        server.stop()
