"""The binding of a source rig's own joints to the model's bones (built by `quadpipe.anatomy.rig`).

For every joint of the rig it says which role's bone the joint rides on and where it sits on
that bone, so that a clip simulated on the 39 roles can be written back onto the rig
(`quadpipe.clip.retarget`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True, eq=False)
class RigJoint:
    """One joint of the source rig and how it moves with the model.

    Attributes:
        name: the rig's name for it.
        parent: its parent's name in the rig, None for the root.
        roles: the roles its bone carries (several for a split bone), empty for an extra bone.
        drive: the role whose bone it rides on: its first role, else its nearest ancestor's
            (the pelvis for joints above the pelvis).
        offset: its rest position minus the drive bone's rest start, metres, body frame.
        end: where its bone ends relative to it (an end site), metres, body frame, if the file says.
        line: its line in the file, for messages.
    """

    name: str
    parent: str | None
    roles: tuple[str, ...]
    drive: str
    offset: np.ndarray
    end: np.ndarray | None = None
    line: int | None = None


@dataclass(frozen=True, eq=False)
class RigBinding:
    """A rig's own joints and the roles they follow (compared by identity: it holds arrays).

    Attributes:
        source: the skeleton file.
        joints: the rig's joints, parents before children.
        carrier: role -> name of the rig joint whose bone carries it (a synthesised role is
            carried by the rig joint it was made from).
        synthesised: the roles the rig has no bone for.
        units: the file's length unit.
        axes: (3, 3) rotation from the file's axes to the body frame.
    """

    source: str
    joints: tuple[RigJoint, ...]
    carrier: dict[str, str]
    synthesised: tuple[str, ...]
    units: str
    axes: np.ndarray

    @property
    def names(self) -> tuple[str, ...]:
        """The rig's joint names, parents first."""
        return tuple(joint.name for joint in self.joints)

    @property
    def extras(self) -> tuple[str, ...]:
        """The rig's joints with no role (they ride rigidly on their parent)."""
        return tuple(joint.name for joint in self.joints if not joint.roles)
