"""The motion of the 39 roles written back onto the source rig's own joints.

An animal imported from a rig keeps its binding (`quadpipe.anatomy.binding.RigBinding`): each of
the rig's joints rides on one role's bone (its own first role, or for an extra bone its parent's)
at a fixed offset. `on_rig` turns a track of roles into a track of the rig's joints: same frames,
the rig's names and hierarchy (extra bones included), each joint following its bone with the
rig's own rest offset. Every exporter writes the result as it writes a track of roles, so the
rig's joints come out in glTF, USD and BVH alike (`bake --skeleton rig`, the default).

Bind frames stay world-aligned, as for the roles (see `quadpipe.clip.model`): the rig's joint
positions are kept, its joint orientations are not read by the importers.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from quadpipe.clip.kinematics import normalize, rotate
from quadpipe.clip.model import AnimalTrack, BodyMesh, Clip, Shape


def on_rigs(clip: Clip) -> Clip:
    """The clip with every animal that came from a rig written on the rig's joints."""
    return dataclasses.replace(clip, animals=[on_rig(track) for track in clip.animals])


def on_rig(track: AnimalTrack) -> AnimalTrack:
    """A track of roles as a track of its rig's own joints (the track itself when it has no rig
    or is on it already). The result keeps the binding, which says the rig file's units and axes.

    Each rig joint j riding on role r at offset d (body frame, rest pose) is at
    `p_r(t) + R_r(t) d` with orientation `R_r(t)`; its rest position is `rest_r + d`.
    """
    binding = track.rig
    if binding is None or track.roles == binding.names:
        return track
    role_index = {role: index for index, role in enumerate(track.roles)}
    names = binding.names
    joint_index = {name: index for index, name in enumerate(names)}
    drive = np.array([role_index[joint.drive] for joint in binding.joints])
    offsets = np.array([joint.offset for joint in binding.joints])
    rotations = normalize(track.rotations[:, drive])
    rest_start = track.rest_start[drive] + offsets
    parents = np.array([joint_index.get(j.parent or "", -1) for j in binding.joints])
    carrier = np.array([joint_index[binding.carrier[role]] for role in track.roles])
    return dataclasses.replace(
        track,
        roles=names,
        parents=parents,
        rest_start=rest_start,
        rest_end=_rest_ends(track, rest_start, parents),
        shapes=_carried_shapes(track, carrier, rest_start),
        positions=track.positions[:, drive] + rotate(rotations, offsets),
        rotations=rotations,
        body=None if track.body is None else _reskinned(track.body, carrier),
    )


def _rest_ends(track: AnimalTrack, rest_start: np.ndarray, parents: np.ndarray) -> np.ndarray:
    """Where each rig bone ends at rest: its end site, else its first child, else its start."""
    assert track.rig is not None, "a rig track's ends come from its binding"
    ends = rest_start.copy()
    for index, joint in enumerate(track.rig.joints):
        children = np.flatnonzero(parents == index)
        if joint.end is not None:
            ends[index] = rest_start[index] + joint.end
        elif children.size:
            ends[index] = rest_start[children[0]]
    return ends


def _carried_shapes(track: AnimalTrack, carrier: np.ndarray, rest_start: np.ndarray) -> list[list[Shape]]:
    """Each rig joint's shapes: those of the roles it carries, moved into its frame."""
    shapes: list[list[Shape]] = [[] for _ in rest_start]
    for role, joint in enumerate(carrier):
        shift = track.rest_start[role] - rest_start[joint]
        for shape in track.shapes[role]:
            moved = tuple(float(v) for v in np.asarray(shape.pos) + shift)
            shapes[joint].append(dataclasses.replace(shape, pos=(moved[0], moved[1], moved[2])))
    return shapes


def _reskinned(body: BodyMesh, carrier: np.ndarray) -> BodyMesh:
    """A body skinned to roles, skinned to the rig joints that carry them: the weights of
    influences that land on one joint are summed into its first (the others keep weight 0)."""
    joints = carrier[body.joints]
    weights = body.weights.copy()
    for k in range(1, joints.shape[1]):
        for earlier in range(k):
            same = (joints[:, k] == joints[:, earlier]) & (weights[:, earlier] > 0)
            weights[same, earlier] += weights[same, k]
            weights[same, k] = 0.0
    joints = np.where(weights > 0, joints, 0)
    return dataclasses.replace(body, joints=joints, weights=weights)
