"""A relative error bound on a constant float field (session 32, user32): the bound is
0, which `volpack compare F --rel-error 1e-3` refused with "an error bound of 0 on float
voxels is lossless coding: leave out the lossy settings" though the user had asked for
1e-3; now it is coded exactly, as an integer volume under a bound below 1 is."""

from __future__ import annotations

import numpy as np
import pytest

from volpack import api
from volpack.format.container import Reader


# float64: the only fast user of its kernel signatures (session 34), in the slow set
@pytest.mark.parametrize("dtype", [np.float32, pytest.param(np.float64, marks=pytest.mark.slow)])
def test_a_constant_field_under_a_relative_bound_is_coded_exactly(dtype):
    a = np.full((12, 14, 16), 3.25, dtype)
    a[0, 0, 0] = np.nan  # a special voxel does not count in the range
    blob = api.compress_array(a, rel_error=1e-3)
    with Reader(blob) as r:
        assert r.header["codec"]["id"] == "lossless"
    assert api.decompress_array(blob).tobytes() == a.tobytes()
