"""OpenGL without a display: the backend MuJoCo renders with, and a context of it.

MuJoCo picks its OpenGL backend from the `MUJOCO_GL` environment variable when `mujoco` is
first imported. This module sets `MUJOCO_GL` (to `egl` unless the user chose one) when it is
imported, which `quadpipe.render` does before anything else, and, so that it does not matter
whether `mujoco` was imported first, `open_gl_context` opens a context of that backend instead
of relying on `mujoco.Renderer`'s choice. `egl` renders on the GPU where there is one and falls
back to Mesa's llvmpipe on CPU; `osmesa` (Debian `libosmesa6`) is CPU only.
"""

from __future__ import annotations

import importlib
import os
from typing import Protocol

from quadpipe.core.errors import QuadpipeError

GL_VARIABLE = "MUJOCO_GL"
"""The environment variable MuJoCo reads its OpenGL backend from."""

DEFAULT_GL_BACKEND = "egl"
"""Headless backend used when the user has not chosen one: GPU when present, else Mesa on CPU."""

GL_BACKENDS = ("egl", "osmesa", "glfw")
"""Backends quadpipe can open a context with (`glfw` needs a display)."""


class GLContext(Protocol):
    """What quadpipe uses of a MuJoCo `GLContext` (the egl, osmesa and glfw ones alike)."""

    def make_current(self) -> None:
        """Make it the thread's current OpenGL context."""

    def free(self) -> None:
        """Release it."""


def gl_backend() -> str:
    """The OpenGL backend to render with: `MUJOCO_GL` if set, else `egl` (and set it).

    Raises:
        QuadpipeError: `MUJOCO_GL` names a backend quadpipe cannot render with.
    """
    backend = (os.environ.get(GL_VARIABLE) or DEFAULT_GL_BACKEND).strip().lower()
    if backend not in GL_BACKENDS:
        raise QuadpipeError.single(
            "unsupported-gl-backend",
            f"cannot render with {GL_VARIABLE}={backend!r}",
            hint=f"set {GL_VARIABLE} to one of {', '.join(GL_BACKENDS)}, or unset it ({DEFAULT_GL_BACKEND} is used)",
        )
    os.environ[GL_VARIABLE] = backend
    return backend


# Before anything imports mujoco where possible, so that `mujoco.Renderer` is headless too.
if GL_VARIABLE not in os.environ or not os.environ[GL_VARIABLE].strip():
    os.environ[GL_VARIABLE] = DEFAULT_GL_BACKEND


def open_gl_context(width: int, height: int) -> GLContext:
    """An OpenGL context of the chosen backend, made current.

    Raises:
        QuadpipeError: code `no-headless-gl` when the backend's libraries are missing or
            refuse to start (MuJoCo's modules raise assorted exception types for this).
    """
    backend = gl_backend()
    try:
        context = importlib.import_module(f"mujoco.{backend}").GLContext(width, height)
        context.make_current()
    except Exception as exc:  # noqa: BLE001 - the system's OpenGL, not quadpipe, failed
        raise QuadpipeError.single(
            "no-headless-gl",
            f"cannot open an OpenGL context with {GL_VARIABLE}={backend}: {type(exc).__name__}: {exc}",
            hint="on Debian install libegl1 (for egl) or libosmesa6 and set MUJOCO_GL=osmesa; see docs/render.md",
        ) from exc
    return context
