"""What the mesh formats (glTF, USD) lay out alike: the names of animals' meshes, and when
props are in the scene.

An animal's mesh is named after it with `BODY_SUFFIX` (`dog_body`), beside the armature or
skeleton that bears the animal's own name. A prop may be out of the scene for some frames (a thrown box waits, parked far under the floor,
until its throw): its pose there means nothing. The exporters draw it only while it is present
(glTF: scale 0 keys with STEP interpolation; USD: `visibility` samples) and hold it, while it is
absent, at the pose of its nearest present frame, so that no interpolation between keys ever
carries it from the parking spot through the ground.
"""

from __future__ import annotations

import numpy as np

from quadpipe.clip.model import PropTrack

BODY_SUFFIX = "_body"
"""An animal's skinned mesh is named after it with this suffix (`dog_body`)."""


def held_poses(prop: PropTrack) -> tuple[np.ndarray, np.ndarray]:
    """The prop's (F, 3) positions and (F, 4) rotations, each absent frame holding the pose of
    the last present frame before it (or, before the first, of the first present frame)."""
    present = prop.presence()
    if present.all() or not present.any():
        return prop.positions, prop.rotations
    frames = np.arange(len(present))
    last_present = np.maximum.accumulate(np.where(present, frames, -1))
    source = np.where(last_present >= 0, last_present, int(np.argmax(present)))
    return prop.positions[source], prop.rotations[source]


def switches(prop: PropTrack) -> tuple[np.ndarray, np.ndarray]:
    """The frames where the prop's presence is set (the first frame and every change) and the
    presence from each on: a step function, to key with STEP interpolation."""
    present = prop.presence()
    frames = np.concatenate([[0], np.flatnonzero(present[1:] != present[:-1]) + 1])
    return frames, present[frames]
