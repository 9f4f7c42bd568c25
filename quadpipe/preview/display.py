"""Whether a preview window can be opened: a display is named, and it answers.

open3d's window set-up dies with a segmentation fault when `DISPLAY` names an X display that
does not answer (a stale `ssh -X` session, a stopped Xvfb), so the display is probed first with
a plain socket connection to the X server the variable names.
"""

from __future__ import annotations

import os
import re
import socket
import sys
from pathlib import Path

from quadpipe.core.errors import QuadpipeError

DISPLAY_PROBE_TIMEOUT_S = 2.0
"""How long to wait for the X server to accept a connection before saying it does not answer."""

X11_TCP_PORT = 6000
"""X display N listens on TCP port 6000 + N (RFC 1013 / the X protocol's convention)."""

X11_SOCKET_FOLDER = Path("/tmp/.X11-unix")
"""Where local X servers put their Unix sockets (`X0` for display :0)."""

_DISPLAY_NAME = re.compile(r"^(?P<host>[^:]*):(?P<number>\d+)(\.\d+)?$")
"""`[host]:display[.screen]`."""

NO_DISPLAY_HINT = "run it on a desktop (or over `ssh -X`); headless, `quadpipe render` writes videos"


def check_display() -> None:
    """Raise unless a window can be opened: on Linux, `DISPLAY` (or `WAYLAND_DISPLAY`) is set and
    the X display it names accepts connections.

    Raises:
        QuadpipeError: `no-display`.
    """
    if not sys.platform.startswith("linux"):
        return
    display = os.environ.get("DISPLAY")
    if not display:
        if os.environ.get("WAYLAND_DISPLAY"):
            return
        raise QuadpipeError.single(
            "no-display",
            "the preview opens a window, and there is no display here (DISPLAY is not set)",
            hint=NO_DISPLAY_HINT,
        )
    problem = _x_display_problem(display)
    if problem is not None:
        raise QuadpipeError.single(
            "no-display",
            f"the preview opens a window, and DISPLAY={display!r} {problem}",
            hint=f"{NO_DISPLAY_HINT}; check that the X server runs, or unset DISPLAY",
        )


def _x_display_problem(display: str) -> str | None:
    """Why the X display named `display` cannot be used, or None when it accepts a connection."""
    match = _DISPLAY_NAME.match(display)
    if match is None:
        return "is not of the form [host]:number[.screen]"
    host, number = match["host"], int(match["number"])
    if host in ("", "unix"):
        local = f"{X11_SOCKET_FOLDER}/X{number}"
        addresses: list[str | tuple[str, int]] = ["\0" + local, local]  # the abstract socket, then the file
    else:
        addresses = [(host, X11_TCP_PORT + number)]
    if any(_accepts(address) for address in addresses):
        return None
    return "does not answer (no X server accepts connections there)"


def _accepts(address: str | tuple[str, int]) -> bool:
    """Whether something accepts a stream connection at `address` (a Unix socket's name, or a
    host and TCP port) within the probe's time."""
    try:
        if isinstance(address, tuple):
            socket.create_connection(address, timeout=DISPLAY_PROBE_TIMEOUT_S).close()
            return True
        with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as probe:
            probe.settimeout(DISPLAY_PROBE_TIMEOUT_S)
            probe.connect(address)
        return True
    except OSError:
        return False
