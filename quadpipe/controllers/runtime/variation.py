"""Natural variation: seeded stride-to-stride timing and a slight left/right asymmetry.

A controller's gait is a clock (its `cycle` elements) and footfalls at fixed phases of it, so
every stride of a clip is the same stride: a robot's. Real animals vary: the stride time of a
walking dog or horse varies by a few per cent from stride to stride, and its left and right
steps differ by a few per cent (no source with figures is collected in
docs/kinematics_references.md yet: 0.03 is a plausible default, not a measured one). `Variation` puts that back into every
controller at once, without touching its file: the runtime scales each cycle's phase advance
by a factor that is drawn anew for each stride (each whole turn of the cycle), and by a fixed
bias that makes one half of every stride a little faster than the other.

- Timing: stride k of a cycle advances at `1 + amount * z_k` times its period's rate, z_k a
  standard normal draw clipped to +-`CLIP_SIGMAS`: stride durations vary with a coefficient of
  variation of about `amount`. Stride lengths vary much less: the locomotion controllers lay
  each stance along a fixed path (`half_sweep`, folded into a constant when the controller is
  compiled), so a quicker stride is mostly a faster one (the dog's walk at 0.03: stride-time
  CV 0.014-0.026 over three seeds, stride-length CV 0.010-0.012 against 0.010 without). A
  length factor would need a value the controller files read (docs/gaits.md, "Natural
  variation").
- Asymmetry: the first half of each stride (from phase 0, the left hind touchdown in the
  shipped gaits, to 0.5) runs at `1 + bias` and the second half at `1 - bias`, with
  `bias = +-SIDE_BIAS_SHARE * amount`, its sign drawn once per animal: in a walk, trot or pace
  the left and the right steps differ in time by up to `2 * bias` (the dog's walk at 0.03:
  3-4 %) and in length by 1-2 %, the step of the quicker half the longer. The footfall phases
  move by at most `bias / 2` of a cycle.

Everything is drawn from `numpy.random.default_rng` seeded with (seed, animal, cycle): the
same seed gives the same clip, byte for byte, and each animal of a scene its own variation.
`amount` 0 (the default) is no variation at all: the runtime then does not even look.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from quadpipe.core.errors import QuadpipeError

MAX_VARIATION = 0.2
"""Largest variation: stride times varying by 20 %, an animal that stumbles rather than walks."""

CLIP_SIGMAS = 2.5
"""Stride factors are drawn from a normal distribution clipped to this many standard deviations
(so no stride at `MAX_VARIATION` runs at half or double time)."""

SIDE_BIAS_SHARE = 1.0
"""The left/right bias as a share of the variation (0.03: one half-stride 3 % quicker than the
stride, the other 3 % slower)."""

FIRST_STRIDES = 256
"""Stride factors drawn at first per cycle and animal; twice as many whenever a clip outlasts them."""


@dataclass(frozen=True)
class Variation:
    """How much a gait varies from stride to stride, and the seed it is drawn from.

    Attributes:
        amount: coefficient of variation of the stride time (0.03: 3 %), 0 to `MAX_VARIATION`.
        seed: the random seed; the same seed gives the same clip.
    """

    amount: float = 0.0
    seed: int = 0

    @property
    def active(self) -> bool:
        """Whether there is any variation."""
        return self.amount > 0.0


def check_variation(amount: float, seed: int, *, names: tuple[str, str] = ("variation", "seed")) -> Variation:
    """The variation of `amount` and `seed`, checked.

    Args:
        names: how the messages name the two values (`--variation`, `--seed` on the command line).

    Raises:
        QuadpipeError: `bad-variation` for an amount that is not a number from 0 to
            `MAX_VARIATION`, or a seed that is negative.
    """
    amount_name, seed_name = names
    if not (math.isfinite(amount) and 0.0 <= amount <= MAX_VARIATION):
        raise QuadpipeError.single(
            "bad-variation",
            f"{amount_name}: {amount:g} is not a variation from 0 to {MAX_VARIATION:g}",
            hint="give the stride time's coefficient of variation: 0.03 varies it by about 3 %, 0 not at all",
        )
    if seed < 0:
        raise QuadpipeError.single(
            "bad-variation", f"{seed_name}: {seed} is negative", hint="give a seed from 0 up, e.g. 1"
        )
    return Variation(float(amount), int(seed))


class StrideClock:
    """Scales the phase advance of a runtime's cycles, per stride, as `Variation` says.

    Args:
        variation: how much, and the seed.
        cycles: number of cycle elements (rows of the runtime's phase table).
        animals: number of animals (its columns).
    """

    def __init__(self, variation: Variation, cycles: int, animals: int):
        self.variation = variation
        self._generators = [
            [np.random.default_rng([variation.seed, animal, cycle]) for animal in range(animals)]
            for cycle in range(cycles)
        ]
        signs = [np.random.default_rng([variation.seed, animal]).choice([-1.0, 1.0]) for animal in range(animals)]
        self.bias = SIDE_BIAS_SHARE * variation.amount * np.array(signs)
        """Per animal: how much faster than its stride the first half of every stride runs."""
        self._bias = self.bias.tolist()
        self._factors = np.ones((cycles, animals, 0))
        self._draw(FIRST_STRIDES)

    def _draw(self, strides: int) -> None:
        """Draw the factors of the next `strides` strides of every cycle and animal."""
        draws = [[generator.standard_normal(strides) for generator in row] for row in self._generators]
        clipped = np.clip(np.array(draws).reshape(*self._factors.shape[:2], strides), -CLIP_SIGMAS, CLIP_SIGMAS)
        self._factors = np.concatenate([self._factors, 1.0 + self.variation.amount * clipped], axis=2)

    def rate(self, cycle: int, animal: int, phase: float) -> float:
        """The factor on a cycle's advance at `phase`: its stride's, times 1 + bias in the
        first half of the stride, 1 - bias in the second."""
        stride = max(math.floor(phase), 0)
        while stride >= self._factors.shape[2]:
            self._draw(self._factors.shape[2])
        half = 1.0 if phase - math.floor(phase) < 0.5 else -1.0
        return float(self._factors[cycle, animal, stride]) * (1.0 + half * self._bias[animal])

    def rates(self, phase: np.ndarray) -> np.ndarray:
        """`rate` for every cycle and animal at `phase` (cycles, animals)."""
        return np.array(
            [
                [self.rate(cycle, animal, value) for animal, value in enumerate(row)]
                for cycle, row in enumerate(phase.tolist())
            ]
        ).reshape(phase.shape)

    def advance(self, before: np.ndarray, phase: np.ndarray) -> None:
        """Scale the advance of `phase` (in place) since it was `before`, by the rates at `before`.

        Scalar loops over the few cycles and animals: every physics step calls this, and numpy's
        vectorised operations cost more than they save on arrays this small (10 us a step).
        """
        for cycle, (row, new_row) in enumerate(zip(before.tolist(), phase.tolist(), strict=True)):
            for animal, (value, new) in enumerate(zip(row, new_row, strict=True)):
                phase[cycle, animal] = value + (new - value) * self.rate(cycle, animal, value)
