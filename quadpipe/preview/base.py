"""The base of both preview modes (live and replay): the clock, named actions, overlay toggles, notices."""

from __future__ import annotations

import abc
from collections.abc import Callable, Sequence
from typing import ParamSpec

import numpy as np

from quadpipe.preview.clock import SLOW_MOTION_RATE, Clock

P = ParamSpec("P")

ActionHandler = Callable[[np.ndarray | None], object]
"""An action: takes the camera's eye position (or None); what it returns is ignored."""


def ignoring_eye(action: Callable[P, object], *args: P.args, **kwargs: P.kwargs) -> ActionHandler:
    """An action handler that calls `action(*args, **kwargs)`, whatever the eye position."""
    return lambda eye: action(*args, **kwargs)


class Preview(abc.ABC):
    """What live and replay previews share: the clock, named actions, overlay toggles, notices."""

    overlay_names: tuple[str, ...] = ()

    def __init__(self, clock: Clock):
        self.clock = clock
        self.shown = set(self.overlay_names)
        self._notices: list[str] = []

    @property
    def error(self) -> str | None:
        """What went wrong, for the window (None: nothing)."""
        return None

    # -------------------------------------------------------------- actions

    def actions(self) -> dict[str, tuple[str, ActionHandler]]:
        """Action name -> (what it does, handler taking the camera's eye position or None)."""
        actions: dict[str, tuple[str, ActionHandler]] = {
            "pause": ("pause / run", lambda eye: self.clock.toggle_pause()),
            "step": ("pause and step one frame", lambda eye: self.clock.step()),
            "reset": ("back to the start", lambda eye: self.reset()),
            "slow_motion": (f"slow motion x{SLOW_MOTION_RATE:g} on / off", lambda eye: self.clock.toggle_slow_motion()),
        }
        for name in self.overlay_names:
            actions[f"toggle_{name}"] = (f"show / hide the {name}", ignoring_eye(self.toggle_overlay, name))
        return actions

    def perform(self, action: str, eye: np.ndarray | Sequence[float] | None = None) -> None:
        """Run a named action; `eye` is the camera position (used by throws).

        Raises:
            KeyError: no such action in this mode.
        """
        self.actions()[action][1](None if eye is None else np.asarray(eye, dtype=float))

    @abc.abstractmethod
    def reset(self) -> None:
        """Back to the start (each mode says what that means)."""

    # -------------------------------------------------------------- overlays and notices

    def toggle_overlay(self, name: str) -> None:
        """Show or hide an overlay layer.

        Raises:
            KeyError: no such layer in this mode.
        """
        if name not in self.overlay_names:
            raise KeyError(name)
        self.shown ^= {name}

    def notify(self, text: str) -> None:
        """Queue a line for the console (the window prints them)."""
        self._notices.append(text)

    def pop_notices(self) -> list[str]:
        """The lines queued since the last call."""
        notices, self._notices = self._notices, []
        return notices

    def _clock_text(self, time: float) -> str:
        state = "paused" if self.clock.paused else "running"
        speed = f" x{self.clock.rate:g}" if self.clock.slow else ""
        return f"t {time:6.2f} s  {state}{speed}"
