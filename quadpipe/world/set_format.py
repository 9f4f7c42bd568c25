"""The `mesh` terrain item of scene files: the animator's set (see `quadpipe.world.sets`).

Its own module so that `quadpipe.world.format` stays short; `format` puts it in the `terrain`
union. Its keys are plain numbers and names (the set is in metres, not in `HP`).
"""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import BaseModel, ConfigDict, Field

MAX_SET_RESOLUTION = 2048
"""Most height-field samples along a set's longer side (a 2048 x 2048 field is 4 M samples)."""


class TerrainMesh(BaseModel):
    """The animator's set: a mesh file, sampled into a height field (see docs/scenes.md, Sets)."""

    model_config = ConfigDict(extra="forbid", populate_by_name=True)

    type: Annotated[Literal["mesh"], Field(description="Terrain type.")]
    file: Annotated[
        str,
        Field(
            min_length=1,
            description="The set's mesh, relative to this scene file: `.obj`, `.ply`, `.glb`/`.gltf`, `.usd`/`.usda`/`.usdc`/`.usdz`. It is placed as it is (its own transform is the identity).",
        ),
    ]
    scale: Annotated[
        float,
        Field(
            1.0,
            gt=0,
            allow_inf_nan=False,
            description="Metres per unit of the file (0.01 for a set in centimetres); a USD stage's `metersPerUnit` multiplies it.",
        ),
    ]
    up: Annotated[
        Literal["y", "z"] | None,
        Field(
            None,
            description="The file's up axis. `y`: the file's x is quadpipe's left, y up, z forward (as the .glb and .bvh exports); `z`: the file's axes are quadpipe's (as the .usd export). Default: y for glTF and OBJ, z for PLY, a USD stage's `upAxis`.",
        ),
    ]
    resolution: Annotated[
        int | None,
        Field(
            None,
            ge=2,
            le=MAX_SET_RESOLUTION,
            description="Height-field samples along the set's longer side (the cell is that side / (resolution - 1)). Default: the set's own detail, a cell as long as the median edge of its triangles seen from above.",
        ),
    ]
