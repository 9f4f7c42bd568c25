"""Views of the kernel's arrays from their addresses (see `kernel.address_table`).

The kernel reaches every array through one table of addresses: a row `(address, d0, d1, d2)`
per array. These helpers make a numba array view of a row, of int64, int32 or float64, with one, two
or three dimensions; a view made from an address carries no reference count (the caller keeps
the arrays alive).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numba
import numpy as np
from numba import types
from numba.extending import intrinsic


def _pointer_typing(typingctx: Any, address: Any, kind: Any) -> tuple[Any, Callable[..., Any]]:
    """Numba's typing of `_pointer`: (an integer, a number class) -> a pointer to that number."""
    target = types.CPointer(kind.instance_type)

    def codegen(context: Any, builder: Any, signature: Any, args: Sequence[Any]) -> Any:
        return builder.inttoptr(args[0], context.get_value_type(target))

    return target(address, kind), codegen


_pointer: Any = intrinsic(_pointer_typing)
"""`_pointer(address, numba.float64)`: an integer address as a typed pointer, for `numba.carray`."""


@numba.njit(cache=True)
def ints1(table: np.ndarray, row: int) -> np.ndarray:
    """The int64 array of address table row `row`, flat."""
    return numba.carray(_pointer(table[row, 0], numba.int64), table[row, 1] * table[row, 2] * table[row, 3])


@numba.njit(cache=True)
def ints2(table: np.ndarray, row: int) -> np.ndarray:
    """The int64 array of address table row `row`, as (d0, d1 x d2)."""
    return numba.carray(_pointer(table[row, 0], numba.int64), (table[row, 1], table[row, 2] * table[row, 3]))


@numba.njit(cache=True)
def int32s2(table: np.ndarray, row: int) -> np.ndarray:
    """The int32 array of address table row `row` (MuJoCo's contact geoms), as (d0, d1 x d2)."""
    return numba.carray(_pointer(table[row, 0], numba.int32), (table[row, 1], table[row, 2] * table[row, 3]))


@numba.njit(cache=True)
def uint32s2(table: np.ndarray, row: int) -> np.ndarray:
    """The uint32 array of address table row `row` (the program, `kernel.CODE_DTYPE`), as (d0, d1 x d2)."""
    return numba.carray(_pointer(table[row, 0], numba.uint32), (table[row, 1], table[row, 2] * table[row, 3]))


@numba.njit(cache=True)
def reals1(table: np.ndarray, row: int) -> np.ndarray:
    """The float64 array of address table row `row`, flat."""
    return numba.carray(_pointer(table[row, 0], numba.float64), table[row, 1] * table[row, 2] * table[row, 3])


@numba.njit(cache=True)
def reals2(table: np.ndarray, row: int) -> np.ndarray:
    """The float64 array of address table row `row`, as (d0, d1 x d2)."""
    return numba.carray(_pointer(table[row, 0], numba.float64), (table[row, 1], table[row, 2] * table[row, 3]))


@numba.njit(cache=True)
def reals3(table: np.ndarray, row: int) -> np.ndarray:
    """The float64 array of address table row `row`, as (d0, d1, d2)."""
    return numba.carray(_pointer(table[row, 0], numba.float64), (table[row, 1], table[row, 2], table[row, 3]))
