"""The fifth held-out set (session 23) loads from the data cache with the shape, dtype and
value range its description gives; skipped where ``scripts/fetch_data.py`` has not run."""

import numpy as np
import pytest

from conftest import benchmark_volume

# name: (shape (z, y, x), dtype, min, max); read once from the packages' files
HELDOUT23 = {
    "mni152_wm": ((189, 233, 197), np.uint8, 0, 255),
    "atlas_jhu_wm_2mm": ((91, 109, 91), np.uint8, 0, 48),
    "mri_emri_dicom": ((10, 64, 64), np.uint16, 0, 467),
    "mri_parrec_phantom": ((9, 64, 64), np.uint16, 0, 1782),
    "mri_afni_epi": ((25, 41, 33), np.int16, 0, 13722),
    "storm_p": ((64, 33, 36), np.float32, -9999.0, 104415.3125),
    "storm_u": ((64, 33, 36), np.float32, -9999.0, 24.307478),
    "mecca_t": ((31, 40, 49), np.float32, 194.8049, 327.85626),
    "sst_monthly": ((12, 91, 181), np.float32, -1.8, 32.11),
    "uas_monthly": ((12, 96, 192), np.float32, -12.624574, 12.427288),
    "seam_ps": ((12, 150, 64), np.float32, 50962.844, 105315.48),
}


@pytest.mark.parametrize("name", sorted(HELDOUT23))
def test_heldout23_volume_loads(name):
    shape, dtype, lo, hi = HELDOUT23[name]
    a = benchmark_volume(name)
    assert a.shape == shape and a.dtype == dtype and a.flags.c_contiguous
    assert np.isclose(float(a.min()), lo, rtol=1e-6) and np.isclose(float(a.max()), hi, rtol=1e-6)
    assert len(np.unique(a)) > 2  # a real image, not a blank or a mask
