"""Maya attribute names: the node attributes that place joints and transforms, short and long."""

from __future__ import annotations

_VECTORS = {
    "t": "translate",
    "r": "rotate",
    "s": "scale",
    "jo": "jointOrient",
    "ra": "rotateAxis",
    "rp": "rotatePivot",
    "sp": "scalePivot",
    "rpt": "rotatePivotTranslate",
    "spt": "scalePivotTranslate",
    "tg[0].tot": "tg[0].targetOffsetTranslate",
    "tg[0].tor": "tg[0].targetOffsetRotate",
    "o": "offset",
}
_SHEAR_PARTS = {"shxy": "shearXY", "shxz": "shearXZ", "shyz": "shearYZ"}
ANGULAR_ATTRIBUTES = {"r", "jo", "ra", "tg[0].tor"}
"""Vector attributes holding angles (in the file's angular unit)."""

ONE_VECTORS = {"s"}
"""Vector attributes whose default is (1, 1, 1) rather than zero."""


def _attribute_table() -> dict[str, tuple[str, int | None]]:
    """Short and long attribute names -> (vector attribute, component index or None)."""
    table: dict[str, tuple[str, int | None]] = {}
    for short, long in _VECTORS.items():
        table[short] = table[long] = (short, None)
        for index, axis in enumerate("xyz"):
            table[short + axis] = table[long + axis.upper()] = (short, index)
    table["sh"] = table["shear"] = ("sh", None)
    for index, (short, long) in enumerate(_SHEAR_PARTS.items()):
        table[short] = table[long] = ("sh", index)
    return table


ATTRIBUTES = _attribute_table()
ROTATE_ORDER_NAMES = {"ro", "rotateOrder"}
SSC_NAMES = {"ssc", "segmentScaleCompensate"}
SCALE_NAMES = {"s", "scale"}
INVERSE_SCALE_NAMES = {"is", "inverseScale"}
