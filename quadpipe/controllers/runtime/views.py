"""The kernel's address table, and views of its arrays from their addresses (`address_table`).

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


TABLE_WIDTH = 4
"""Columns of an address table row: the address, then up to three dimensions (missing ones 1)."""


@numba.njit(cache=True)
def table_at(address: int, rows: int) -> np.ndarray:
    """The address table at `address`, `rows` rows: the kernel takes it by address, an integer,
    which numba's dispatcher types faster than an array (~0.04 µs, where an array takes ~0.2)."""
    return numba.carray(_pointer(address, numba.int64), (rows, TABLE_WIDTH))


def address_row(array: np.ndarray, dtype: type) -> tuple[int, int, int, int]:
    """The address table row of a C-contiguous array of `dtype` (see `address_table`).

    Raises:
        ValueError: the array is not C-contiguous, not of `dtype`, or has more than three dimensions.
    """
    if array.dtype != dtype or not array.flags.c_contiguous or array.ndim > 3:
        raise ValueError(
            f"the kernel reads C-contiguous {np.dtype(dtype)} arrays of up to 3 dimensions, not {array.dtype} {array.shape}"
        )
    shape = array.shape + (1,) * (3 - array.ndim)
    return (array.ctypes.data, shape[0], shape[1], shape[2])


def contact_row(view: np.ndarray) -> tuple[int, int, int, int]:
    """The address table row of a field of MuJoCo's contact structs (`view`: a strided view, a
    row per contact, of int32 geoms or float64 frames): row c of the kernel's view starts at
    contact c's field, its whole struct wide, so its first columns are that field.

    Raises:
        ValueError: the struct's size is not a whole number of the field's items.
    """
    rows, stride = view.shape[0], view.strides[0]
    if stride % view.itemsize or view.strides[1] != view.itemsize:
        raise ValueError(f"contact structs of {stride} bytes are not a whole number of {view.dtype} items")
    return (view.ctypes.data, rows, stride // view.itemsize, 1)


def address_table(rows: Sequence[tuple[int, int, int, int]]) -> np.ndarray:
    """The kernel's address table: a row `(address, d0, d1, d2)` per array (`address_row`), in
    the kernel's order (`kernel.CODE`, `INTEGER_ARRAYS`, `REAL_ARRAYS`, `MUJOCO_ARRAYS`, the
    contacts (`contact_row`), then the model and the data, `(address, 0, 0, 0)`). The caller
    keeps every array alive while the kernel runs on the table."""
    return np.array(rows, dtype=np.int64).reshape(-1, TABLE_WIDTH)
