"""MuJoCo's C functions, callable from the controller kernel.

The kernel calls MuJoCo's own `mj_ray` directly (no Python per ray): numba links the C
function by name from MuJoCo's shared library, which this module makes visible to it once,
on import. The kernel passes the model, the data and arrays by address (`MjModel._address`,
`MjData._address`, `ndarray.ctypes.data`).

Numba's cache of a kernel function is invalidated by changes to the kernel's own file only:
a changed declaration here needs `kernel.py` touched (or the cache cleared).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import mujoco
from llvmlite import binding
from numba import types

MUJOCO_LIBRARIES = ("libmujoco.so.*", "libmujoco*.dylib", "mujoco.dll")
"""File names of MuJoCo's C library in the `mujoco` package (Linux, macOS, Windows)."""


def _mujoco_library() -> Path:
    """The C library file of the `mujoco` package."""
    folder = Path(mujoco.__file__).parent
    for pattern in MUJOCO_LIBRARIES:
        found = sorted(folder.glob(pattern))
        if found:
            return found[0]
    raise ImportError(f"no MuJoCo C library ({', '.join(MUJOCO_LIBRARIES)}) in {folder}")


binding.load_library_permanently(str(_mujoco_library()))

ADDRESS = types.intp
"""A pointer argument, passed as its address."""

mj_ray: Any = types.ExternalFunction(
    "mj_ray", types.float64(ADDRESS, ADDRESS, ADDRESS, ADDRESS, ADDRESS, types.uint8, types.int32, ADDRESS, ADDRESS)
)
"""`mjtNum mj_ray(const mjModel* m, const mjData* d, const mjtNum pnt[3], const mjtNum vec[3],
const mjtByte* geomgroup, mjtBool flg_static, int bodyexclude, int geomid[1], mjtNum normal[3])`:
the distance along `vec` from `pnt` to the first geom hit, -1 when none is (geomid and normal
may be 0, for none)."""
