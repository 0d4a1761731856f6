"""The default version's pruned selection for integer bricks (lossless.PRUNE) against the
exhaustive one: the bytes within the tolerance of the exhaustive coding, the voxels back
exactly, and the exhaustive selection reproducing the files of the base tree."""

from __future__ import annotations

import hashlib

import numpy as np
import pytest
from conftest import benchmark_volume, smooth_volume

from volpack import api
from volpack.volume_codec import lossless

# The task's tolerance on a file (0.1 % on average over the corpus, 0.3 % at worst).
TOLERANCE = 0.003
# sha256 of api.compress_array of these volumes on the base tree (0bc3e80, before the
# pruned selection existed): the exhaustive selection must reproduce them.
BASE = {
    "mri_itk_t1": (183095, "39ebf43ee2b7c2e362ebfd2eaf53937e6d2a49b14bf27751bc7d1c037bbfdb71"),
    "ct_head": (263193, "ab4cb8efb6bad354aedc44db5e8e97c225cc86f8052ad135f2aac07f9fe9731b"),
}
CROPS = {"mri_itk_t1": np.s_[:], "ct_head": np.s_[:40, 60:156, 80:176]}


def real(name: str) -> np.ndarray:
    return np.ascontiguousarray(np.asarray(benchmark_volume(name))[CROPS.get(name, np.s_[:])])


def both(a: np.ndarray, monkeypatch, **opts) -> tuple[bytes, bytes]:
    monkeypatch.setattr(lossless, "PRUNE", True)
    pruned = api.compress_array(a, **opts)
    monkeypatch.setattr(lossless, "PRUNE", False)
    return pruned, api.compress_array(a, **opts)


@pytest.mark.parametrize(
    "name",
    [
        "mri_itk_t1",
        "ct_head",
        "labels_itk_skullstrip",
        pytest.param("brainsmall", marks=pytest.mark.slow),
    ],
)
def test_pruned_selection_codes_real_volumes_within_the_tolerance(name, monkeypatch):
    # (without LOWM, session 39, which the base tree lacked: with it both files are
    # shorter, mri_itk_t1's exhaustive one 183,081 B and ct_head's 263,168 B)
    monkeypatch.setattr(lossless, "LOWM", False)
    a = real(name)
    pruned, exhaustive = both(a, monkeypatch)
    assert len(pruned) <= (1 + TOLERANCE) * len(exhaustive), (len(pruned), len(exhaustive))
    np.testing.assert_array_equal(api.decompress_array(pruned), a)
    if name in BASE:  # the exhaustive selection is the base tree's, byte for byte
        assert (len(exhaustive), hashlib.sha256(exhaustive).hexdigest()) == BASE[name]


def test_pruned_selection_runs_and_keeps_the_bytes_near(monkeypatch):
    """A smooth noisy volume with a flat background (the mask, the palette ranks and
    the chain's variants all in play): the sample's plan is made for every brick, and the
    file stays within the tolerance of the exhaustive one."""
    rng = np.random.default_rng(30)
    a = smooth_volume((48, 64, 64), np.int16, seed=30).astype(np.int32) * 3
    a += rng.integers(-3, 4, a.shape)
    a[:, :20] = -7
    plans = []
    plan = lossless._FitChain.plan
    monkeypatch.setattr(lossless._FitChain, "plan", lambda self: plans.append(1) or plan(self))
    pruned, exhaustive = both(a.astype(np.int16), monkeypatch, brick=64)
    assert plans, "the pruned selection did not run"
    assert len(pruned) <= (1 + TOLERANCE) * len(exhaustive), (len(pruned), len(exhaustive))
    np.testing.assert_array_equal(api.decompress_array(pruned), a.astype(np.int16))


def test_pruned_selection_is_deterministic_for_any_worker_count():
    rng = np.random.default_rng(31)
    a = np.cumsum(rng.integers(-2, 3, size=(64, 64, 96)), axis=2).astype(np.int16)
    one = api.compress_array(a, brick=(64, 64, 48), workers=1)
    assert api.compress_array(a, brick=(64, 64, 48), workers=2) == one


def test_sample_slabs_cover_the_axis_with_context():
    index, context = lossless._sample(64)
    assert len(index) == len(context) == lossless.SLABS * (64 // 16 + lossless.JOIN)
    assert index.min() >= 0 and index.max() < 64
    starts = index[~context].reshape(lossless.SLABS, -1)[:, 0]
    assert (np.diff(starts) >= 64 // lossless.SLABS - 1).all()  # spread, not one slab
    assert (
        index[context] == np.concatenate([np.arange(s - lossless.JOIN, s) for s in starts])
    ).all()
