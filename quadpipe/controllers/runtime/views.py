"""The kernel's address table, and views of its arrays from their addresses (`address_table`).

The kernel reaches every array through one table of addresses: a row `(address, d0, d1, d2)`
per array. These helpers make a numba array view of a row, of int64, int32 or float64, with one, two
or three dimensions; a view made from an address carries no reference count (the caller keeps
the arrays alive).
"""

from __future__ import annotations

import ctypes
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


@numba.njit(cache=True, inline="always")
def real_at(address: int) -> float:
    """The float64 at `address` (a scalar of MuJoCo's data: `data_field`)."""
    return numba.carray(_pointer(address, numba.float64), 1)[0]


@numba.njit(cache=True, inline="always")
def int32_at(address: int) -> int:
    """The int32 at `address` (a scalar of MuJoCo's data: `data_field`)."""
    return numba.carray(_pointer(address, numba.int32), 1)[0]


PROBES = {np.dtype(np.float64): (-1.2345678901234567e-300, 3.3e-300), np.dtype(np.int32): (-123456789, -987654321)}
"""Two values per type that `data_field` writes into a field to find it (values MuJoCo never
holds there: a negative count, a time of -1e-300 s)."""


def data_field(data: Any, name: str, dtype: type) -> int:
    """The address of the scalar field `name` (of `dtype`: float64 or int32) of MuJoCo's data
    struct `data` (`mujoco.MjData`), for the kernel to read it itself.

    The struct's layout changes between MuJoCo versions, so the field is found where writing
    two probe values into it (`PROBES`, the field's value put back after) shows them, in the
    part of the struct between its arrays `solver_fwdinv` and `energy` (MuJoCo's sizes, such
    as `ncon`, and its `time`), once per process (`_FIELD_OFFSETS`: one MuJoCo library, one
    layout).

    Raises:
        ValueError: the field is not found there, or at more than one place.
    """
    key = (name, np.dtype(dtype))
    if key not in _FIELD_OFFSETS:
        _FIELD_OFFSETS[key] = _probe_field(data, name, dtype) - data._address
    return int(data._address) + _FIELD_OFFSETS[key]


_FIELD_OFFSETS: dict[tuple[str, np.dtype], int] = {}
"""The offset in MuJoCo's data struct of each field `data_field` found."""


def _probe_field(data: Any, name: str, dtype: type) -> int:
    """The address of field `name` of `data`, found by probing (see `data_field`)."""
    kind, kept = np.dtype(dtype), getattr(data, name)
    start = data.solver_fwdinv.ctypes.data + data.solver_fwdinv.nbytes
    start += -start % kind.itemsize  # the field is aligned
    count = (data.energy.ctypes.data - start) // kind.itemsize
    memory = np.ctypeslib.as_array((ctypes.c_char * (count * kind.itemsize)).from_address(start)).view(kind)
    found = np.ones(count, dtype=bool)
    try:
        for probe in PROBES[kind]:
            setattr(data, name, probe)
            found &= memory == kind.type(probe)
    finally:
        setattr(data, name, kept)
    places = np.flatnonzero(found)
    if len(places) != 1:
        raise ValueError(f"MuJoCo's data field {name!r} is not where the kernel looks for it")
    return start + int(places[0]) * kind.itemsize


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
