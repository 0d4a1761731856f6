"""scripts/bench_lossy.py's .npy inputs and declared fill value (session 37, psnr37)."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

SCRIPTS = str(Path(__file__).resolve().parents[1] / "scripts")
if SCRIPTS not in sys.path:
    sys.path.insert(0, SCRIPTS)
bench = pytest.importorskip("bench_lossy")


def test_a_npy_path_is_a_dataset_named_by_its_stem(tmp_path):
    a = np.arange(60, dtype=">f4").reshape(3, 4, 5)
    np.save(tmp_path / "field_a.npy", a)
    got, desc = bench.load_dataset(str(tmp_path / "field_a.npy"))
    assert got.dtype == np.float32 and got.dtype.isnative and np.array_equal(got, a)
    assert bench.dataset_name(str(tmp_path / "field_a.npy")) == "field_a"
    assert bench.dataset_name("climate_t") == "climate_t"
    np.save(tmp_path / "c.npy", np.zeros(3, complex))
    with pytest.raises(TypeError, match="float or integer"):
        bench.load_dataset(str(tmp_path / "c.npy"))


def test_a_declared_fill_is_kept_from_peers_and_errors():
    a = np.linspace(0, 1, 4 * 5 * 6, dtype=np.float32).reshape(4, 5, 6)
    a[0, :2] = 1e35
    mask = bench.fill_mask(a, 1e35)
    assert mask.sum() == 12 and bench.fill_mask(a, -9999.0) is None
    assert bench.fill_mask(a, None) is None
    x = bench.peer_copy(a, mask)  # each fill voxel: its nearest other voxel's value
    assert x.max() <= 1 and np.array_equal(x[~mask], a[~mask]) and x[0, 0, 0] == a[1, 0, 0]
    assert bench.bounds_for(a[~mask])[0] == pytest.approx(
        1e-2 * float(a[~mask].max() - a[~mask].min()), rel=1e-3
    )

    def decode(back):  # a method that keeps the fill, or one that loses it
        return bench.Method("m", lambda x_, s: (back, 1), lambda b, x_: b, False)

    good = a.copy()
    good[~mask] += np.float32(0.001)
    r = bench.measure(decode(good), a, a, 0.002, 1)  # 0.002: the bound
    assert r["psnr_db"] > 600  # without the mask: the fill sets the peak
    r = bench.measure(decode(good), a, a, 0.002, 1, mask=mask)
    assert r["bound_ok"] and r["max_abs_err"] == pytest.approx(0.001, rel=1e-3)
    assert 55 < r["psnr_db"] < 65
    assert "fill_lost" not in r
    lost = good.copy()
    lost[mask] = 0.0
    r = bench.measure(decode(lost), a, a, 0.002, 1, mask=mask)
    assert r["fill_lost"] and not r["bound_ok"]
