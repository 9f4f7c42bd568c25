"""How the kernel reads a program and MuJoCo's contacts (`quadpipe.controllers.runtime.kernel`).

A runtime hands the kernel its program as `CODE_DTYPE` (unsigned 32-bit: half the bytes of
int64, and indexes numba need not test for a negative value), and MuJoCo's contacts through
rows of its address table rather than as arguments of every call. The program must keep every
field it was lowered with, and a field the type cannot hold must be refused, never wrapped.
"""

from __future__ import annotations

import numpy as np
import pytest

from quadpipe.controllers.runtime.kernel import CODE_DTYPE, program_array
from quadpipe.controllers.runtime.runtime import ControllerRuntime
from quadpipe.controllers.runtime.views import contact_row
from quadpipe.core import configs
from tests.test_folding import compiled, dog_world


@pytest.mark.parametrize("controller", configs.available("controllers"))
def test_a_runtime_runs_its_program_as_lowered_in_the_kernels_type(controller: str) -> None:
    sim = dog_world()
    runtime = ControllerRuntime(compiled(controller), sim.model, sim.placements)
    code = runtime._arrays["code"]
    assert code.dtype == CODE_DTYPE and code.flags.c_contiguous
    np.testing.assert_array_equal(code.astype(np.int64), runtime.program.code)
    runtime.release()


@pytest.mark.parametrize("field", [-1, int(np.iinfo(CODE_DTYPE).max) + 1])
def test_a_field_beyond_the_program_type_is_refused(field: int) -> None:
    code = np.zeros((3, 7), dtype=np.int64)
    code[1, 6] = field  # a transition's bit mask of source states, say
    with pytest.raises(ValueError, match="beyond the kernel"):
        program_array(code)


def test_a_contact_row_spans_its_struct() -> None:
    structs = np.zeros((5, 73))  # five 584-byte structs, as MuJoCo's contacts
    frames = structs[:, 10:19]
    address, rows, width, depth = contact_row(frames)
    assert (address, rows, width, depth) == (frames.ctypes.data, 5, 73, 1)
    odd = np.zeros((5, 147), dtype=np.int32).view(np.uint8)[:, 2:586].view(np.float64)  # 588-byte structs
    with pytest.raises(ValueError, match="whole number"):
        contact_row(odd[:, :9])
