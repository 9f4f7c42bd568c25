"""The preview clock: wall time turned into whole ticks of simulated time.

Real time, paused, single steps, slow motion (x0.25), with a capped catch-up so that one slow
frame does not make the next slower.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

SLOW_MOTION_RATE = 0.25
"""Simulated seconds per wall second in slow motion."""

MAX_CATCH_UP_S = 0.1
"""Most wall time one `advance` makes up for, seconds: after a longer frame (a window dragged,
a breakpoint) the simulation drops the rest instead of spiralling into ever longer frames."""


@dataclass
class Clock:
    """Turns wall time into whole ticks of simulated time.

    Attributes:
        tick_s: simulated seconds per tick (a physics step, or a clip frame).
        step_ticks: ticks one single step moves (one 1/30 s frame).
        paused: no ticks from wall time (single steps still go).
        slow: slow motion (`SLOW_MOTION_RATE`).
    """

    tick_s: float
    step_ticks: int = 1
    paused: bool = False
    slow: bool = False
    _owed_s: float = field(default=0.0, init=False, repr=False)
    _queued: int = field(default=0, init=False, repr=False)

    @property
    def rate(self) -> float:
        """Simulated seconds per wall second while running."""
        return SLOW_MOTION_RATE if self.slow else 1.0

    def advance(self, wall_dt: float) -> int:
        """The ticks due after `wall_dt` more wall seconds (at most `MAX_CATCH_UP_S` worth), plus queued steps."""
        ticks, self._queued = self._queued, 0
        if self.paused:
            return ticks
        self._owed_s += min(max(wall_dt, 0.0), MAX_CATCH_UP_S) * self.rate
        due = math.floor(self._owed_s / self.tick_s + 1e-9)
        self._owed_s = max(self._owed_s - due * self.tick_s, 0.0)
        return ticks + due

    def toggle_pause(self) -> None:
        """Pause, or run again."""
        self.paused = not self.paused
        self._owed_s = 0.0

    def step(self) -> None:
        """Pause, and queue one step for the next `advance`."""
        self.paused = True
        self._owed_s = 0.0
        self._queued += self.step_ticks

    def toggle_slow_motion(self) -> None:
        """Slow motion on or off."""
        self.slow = not self.slow

    def reset(self) -> None:
        """Forget owed time and queued steps (the pause and speed stay)."""
        self._owed_s, self._queued = 0.0, 0
