"""Size rules: everything about an animal's physical model that depends on its size.

One rule per quantity, each a small function of the pelvis height HP (metres):

- **Bone radius** (thesis §3.1): `HP/75 + 0.1 cm`, and never larger than the bone's own length
  or a neighbour's.
- **Contact softness**: MuJoCo's soft constraints behave like a spring-damper
  with time constant `tau`; a body resting on them sinks about `g * tau^2`, and a foot landing
  at speed v goes about `v * tau / e` deep. A fixed `tau` would let a rat sink through its own
  bones while an elephant barely notices, so `tau` follows the animal's natural time
  `sqrt(HP / g)`: `tau = 0.02 * sqrt(HP / g)` (dynamic similarity: every animal sinks the same
  fraction of HP). 0.02 keeps a foot that lands at two natural velocities `sqrt(g HP)` (a
  trot's touchdown) within 1.5 % HP of the floor (#13); the thesis-era 0.079 (MuJoCo's default
  0.02 s for the thesis's dog) let it go 6 % HP deep and spring back out of the floor, so
  planted feet skated (docs/gaits.md, "A stiff contact"). That is 5.2 ms for the dog, 1.0 ms for
  the rat, 11 ms for the elephant.
- **Joint-limit softness**: the joint limits stand for ligaments and joint capsules, which
  give: their time constant stays the thesis-era `0.079 * sqrt(HP / g)` (MuJoCo's default
  0.02 s for the thesis's dog). Stiff limits on a stiff floor made a dropped ragdoll prop
  itself up on locked joints and creep for seconds before it toppled.
- **Impedance**: `solimp` (0.95, 0.99, width) instead of MuJoCo's (0.9, 0.95, 1 mm): stiffer
  constraints; the width over which impedance ramps up is 1 mm for the dog, scaled with HP.
- **Time step**: MuJoCo needs `tau >= 2 * timestep` for its constraints to stay stable, so the
  thesis's fixed 1/120 s step is split into as many equal substeps as that needs: two for the
  elephant, three from the lion to the horse, four for the pig, the goat and the dog, five for
  the cat, seventeen for the rat.
"""

from __future__ import annotations

import math

GRAVITY = 9.81
"""Standard gravity, m/s^2."""

RADIUS_PER_HP = 1.0 / 75.0
"""Thesis radius rule, slope: radius grows by HP/75."""

RADIUS_OFFSET_M = 0.001
"""Thesis radius rule, offset: + 0.1 cm."""

SOFTNESS_PER_NATURAL_TIME = 0.02
"""Constraint time constant as a fraction of sqrt(HP/g) (5.2 ms for the thesis's dog)."""

LIMIT_SOFTNESS_PER_NATURAL_TIME = 0.079
"""Joint-limit time constant as a fraction of sqrt(HP/g) (0.02 s for the thesis's dog)."""

FRAME_STEP_S = 1.0 / 120.0
"""The thesis's fixed physics step: 1/120 s, 4 steps per 30 fps frame."""

STEPS_PER_FRAME = 4
"""Physics steps (of FRAME_STEP_S) per displayed frame."""

FRAME_RATE = 30
"""Frames per second of clips: STEPS_PER_FRAME * FRAME_STEP_S = 1/30 s."""

TAU_PER_STEP = 2.0
"""MuJoCo's stability bound: the constraint time constant must be at least 2 time steps."""

SOLVER_ITERATIONS = 32
"""The thesis needed at least ~32 constraint iterations (Appendix A)."""


IMPEDANCE_MIN, IMPEDANCE_MAX = 0.95, 0.99
"""solimp d0 and dwidth: constraint impedance at zero and at full penetration width."""

IMPEDANCE_WIDTH_PER_HP = 0.001 / 0.6556
"""solimp width per metre of HP: 1 mm for the thesis's dog."""

IMPEDANCE_MIDPOINT, IMPEDANCE_POWER = 0.5, 2.0
"""solimp midpoint and power: MuJoCo's defaults."""


def constraint_impedance(pelvis_height: float) -> list[float]:
    """MuJoCo `solimp` for an animal's contacts and joint limits."""
    width = IMPEDANCE_WIDTH_PER_HP * pelvis_height
    return [IMPEDANCE_MIN, IMPEDANCE_MAX, width, IMPEDANCE_MIDPOINT, IMPEDANCE_POWER]


def bone_radius(pelvis_height: float) -> float:
    """The thesis's uniform bone radius for an animal, in metres."""
    return pelvis_height * RADIUS_PER_HP + RADIUS_OFFSET_M


def natural_time(pelvis_height: float) -> float:
    """sqrt(HP / g), in seconds: the time scale of a pendulum as tall as the animal."""
    return math.sqrt(pelvis_height / GRAVITY)


def constraint_time_constant(pelvis_height: float) -> float:
    """MuJoCo `solref` time constant for contacts, in seconds: the stiffest constraint."""
    return SOFTNESS_PER_NATURAL_TIME * natural_time(pelvis_height)


def joint_limit_time_constant(pelvis_height: float) -> float:
    """MuJoCo `solref` time constant for joint limits, in seconds."""
    return LIMIT_SOFTNESS_PER_NATURAL_TIME * natural_time(pelvis_height)


def substeps(pelvis_height: float) -> int:
    """How many equal substeps each 1/120 s step needs for this animal's constraints."""
    largest_step = constraint_time_constant(pelvis_height) / TAU_PER_STEP
    return max(1, math.ceil(FRAME_STEP_S / largest_step - 1e-9))


def timestep(pelvis_height: float) -> float:
    """The animal's physics time step, in seconds: 1/120 s divided into `substeps`."""
    return FRAME_STEP_S / substeps(pelvis_height)


def natural_frame_rate(pelvis_height: float, frames_per_natural_time: float) -> float:
    """The recording rate (frames per second) that divides the animal's physics rate and is
    nearest to `frames_per_natural_time` frames per natural time sqrt(HP / g)."""
    step = timestep(pelvis_height)
    steps = max(1, round(natural_time(pelvis_height) / (frames_per_natural_time * step)))
    return 1.0 / (steps * step)
