"""Summaries of animals and their models, for `quadpipe animals` and `quadpipe inspect`."""

from __future__ import annotations

import math
from typing import Any

from quadpipe.anatomy import roles
from quadpipe.animals.library import Animal
from quadpipe.animals.model import BuiltAnimal


def animal_row(built: BuiltAnimal) -> dict[str, Any]:
    """One line of `quadpipe animals`: name, HP, mass, bones, degrees of freedom, time step."""
    animal = built.animal
    return {
        "name": animal.name,
        "hp_cm": round(animal.pelvis_height * 100, 2),
        "mass_kg": animal.mass_kg,
        "bones": len(animal.skeleton.bones),
        "dof": sum(limit.dof for limit in animal.limits.values()),
        "radius_cm": round(built.radius * 100, 3),
        "timestep_s": built.timestep,
    }


def bone_rows(built: BuiltAnimal) -> list[dict[str, Any]]:
    """Per-bone details: role, file name, parent, length, radius, mass, limits in degrees."""
    animal: Animal = built.animal
    rows = []
    for role, bone in animal.skeleton.bones.items():
        limit = animal.limits.get(role)
        rows.append(
            {
                "role": role,
                "name": bone.name,
                "parent": roles.PARENT[role],
                "length_cm": round(bone.length * 100, 3),
                "radius_cm": round(built.radii[role] * 100, 3),
                "mass_kg": round(built.masses[role], 4),
                "dof": limit.dof if limit else 6,
                "limits_deg": None
                if limit is None
                else [
                    round(math.degrees(v), 2) for v in (limit.twist_min, limit.twist_max, limit.swing1, limit.swing2)
                ],
            }
        )
    return rows
