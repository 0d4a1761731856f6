"""Motion estimation and compensation against slow references (tests/naive_motion.py)."""

from __future__ import annotations

import naive_motion
import numpy as np
import pytest

from volpack import synth
from volpack.animation import motion

# slow: motion estimation kernels: long to compile (pytest -m slow runs them; .ci/run does)
pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def head16():
    return synth.head((16, 16, 24))


@pytest.mark.parametrize("n", [1, 5, 8, 12, 16, 21, 40])
@pytest.mark.parametrize("windowed", [True, False])
def test_window_weights_sum_to_one(n, windowed):
    blocks, weights = motion.window_table(n, windowed)
    assert np.allclose(weights.sum(1), 1.0, rtol=0, atol=1e-15)
    for c in range(n):  # interior weights follow the 12-voxel window formula
        b = blocks[c, 0]
        u = c - 8 * b + 2
        if windowed and weights[c, 1] > 0:
            assert weights[c, 0] == pytest.approx(naive_motion.window(u), abs=1e-15)
    starts, wts = motion.block_windows(n, windowed)
    rebuilt = np.zeros(n)
    for b in range(len(starts)):
        for k in range(wts.shape[1]):
            if starts[b] + k < n:
                rebuilt[starts[b] + k] += wts[b, k]
    assert np.allclose(rebuilt, 1.0, atol=1e-15)


def _random_field(rng, grid, two_way, sub=True, span=None):
    mode = rng.choice([0, 1, 2, 3] if two_way else [0, 3], size=grid).astype(np.uint8)
    span = span or (9 if sub else 2)
    fwd = rng.integers(-span, span + 1, (*grid, 3)) * (1 if sub else 4)
    bwd = rng.integers(-span, span + 1, (*grid, 3)) * (1 if sub else 4)
    mean = rng.integers(0, 255, grid).astype(np.float64)
    return motion.MotionField(mode, fwd.astype(np.int64), bwd.astype(np.int64), mean)


@pytest.mark.parametrize("windowed", [True, False])
@pytest.mark.parametrize("two_way", [True, False])
def test_compensate_matches_naive(rng, windowed, two_way):
    shape = (9, 13, 17)  # partial blocks on every axis
    prev = rng.integers(0, 255, shape).astype(np.uint8)
    nxt = rng.integers(0, 255, shape).astype(np.uint8)
    f = _random_field(rng, motion.block_grid(shape), two_way)
    comp = "windowed" if windowed else "block"
    got = motion.compensate(f, prev, nxt if two_way else None, compensation=comp)
    want = naive_motion.compensate(
        f.mode, f.fwd, f.bwd, f.mean, prev, nxt if two_way else prev, windowed
    )
    assert np.allclose(got, want, rtol=0, atol=1e-9)


@pytest.mark.parametrize(
    "vectors,dtype",
    [("whole", "u1"), ("far sub-voxel", "u1"), ("far whole", "u1"), ("mixed", "u1"),
     ("mixed", "f8"), ("far sub-voxel", "f8")],
)  # fmt: skip
def test_compensate_matches_naive_on_every_path(rng, vectors, dtype):
    """Whole vectors in both directions, vectors reaching past the stored grid margin
    (clamped reads), and bidirectional blocks mixing a whole and a sub-voxel vector (read
    from the grid for 8-bit frames, which it holds exactly, from the frame for float64)."""
    shape = (19, 13, 17)
    prev = rng.integers(0, 255, shape).astype(dtype)
    nxt = rng.integers(0, 255, shape).astype(dtype)
    if dtype == "f8":
        prev += rng.random(shape) / 3  # not representable in float32
    grid = motion.block_grid(shape)
    if vectors == "mixed":
        f = _random_field(rng, grid, True)
        whole = rng.random(grid) < 0.5
        f.fwd[whole] &= ~3
    else:
        sub = vectors == "far sub-voxel"
        span = {"whole": 2, "far sub-voxel": 40, "far whole": 9}[vectors]
        f = _random_field(rng, grid, True, sub=sub, span=span)
    got = motion.compensate(f, prev, nxt)
    want = naive_motion.compensate(f.mode, f.fwd, f.bwd, f.mean, prev, nxt, True)
    assert np.allclose(got, want, rtol=0, atol=1e-9)


def test_int16_grid_of_8_bit_frames_clamps_overshoot():
    """The 8-tap filter overshoots (1.375x per pass for a pattern matching its signs):
    three passes over an 8-bit product pattern pass +512, where the int16 64ths clamp."""
    p = np.array([0, 1, 0, 1, 1, 0, 1, 0, 0, 1, 0, 1, 1, 0, 1, 0])
    ref = (255 * p[:, None, None] * p[None, :, None] * p[None, None, :]).astype(np.uint8)
    up = motion.upsample(ref)
    assert up.dtype == np.int16 and up.max() == 32767
    want = naive_motion.upsample(ref)
    assert want.max() == 32767 / 64
    assert np.array_equal(motion.interleave(up), want)


@pytest.mark.parametrize("dtype", ["i2", "u1"])
def test_grid_margin_holds_clamped_samples(rng, dtype):
    ref = rng.integers(0, 256, (5, 7, 9)).astype(dtype)
    up, want = motion.upsample(ref), naive_motion.upsample(ref)
    unit = 64.0 if dtype == "u1" else 1.0  # 8-bit frames: int16 64ths
    m = motion.MARGIN
    for pz, py, px in np.ndindex(2, 2, 2):
        idx = [
            np.clip(2 * (np.arange(n + 2 * m) - m) + p, 0, 2 * n - 2)
            for n, p in zip(ref.shape, (pz, py, px))
        ]
        assert np.array_equal(up[pz, py, px], (want[np.ix_(*idx)] * unit).astype(up.dtype))


def test_constant_reference_predicts_constant(rng):
    shape = (20, 24, 19)
    ref = np.full(shape, 77, np.int16)
    f = _random_field(rng, motion.block_grid(shape), True)
    f = motion.MotionField(np.minimum(f.mode, 2), f.fwd, f.bwd, f.mean)  # no intra
    p = motion.compensate(f, ref, ref)
    assert np.allclose(p, 77.0, rtol=0, atol=1e-9)


@pytest.mark.parametrize("dtype", ["i2", "f8", "u1", "i1"])
def test_upsample_matches_naive(rng, dtype):
    lo, hi = (0, 256) if dtype == "u1" else (-128, 128) if dtype == "i1" else (-300, 300)
    ref = rng.integers(lo, hi, (5, 7, 9)).astype(dtype)
    if dtype == "f8":
        ref += rng.random(ref.shape)  # each pass rounds to float32: the order of axes shows
    up = motion.interleave(motion.upsample(ref))
    assert np.allclose(up, naive_motion.upsample(ref), rtol=0, atol=1e-9)


@pytest.mark.parametrize("penalty", [0.0, 3.0])
def test_exhaustive_matches_naive(head16, penalty):
    ref = head16
    cur = np.roll(head16, (1, -2, 1), (0, 1, 2))
    cur[:, :3] = 17  # a region no vector predicts well
    v, c = motion.estimate(
        cur, ref, radius=3, method="exhaustive", precision="whole", penalty=penalty
    )
    nv, nc = naive_motion.exhaustive(cur, ref, 3, penalty)
    assert np.array_equal(v, nv)
    assert np.allclose(c, nc, rtol=1e-12)


def test_fast_finds_translation_and_never_beats_exhaustive():
    vol = synth.head((32, 32, 32))
    ref = vol
    cur = np.empty_like(vol)
    cur[:] = vol[np.ix_(*(np.clip(np.arange(32) - d, 0, 31) for d in (2, -3, 1)))]
    fast, cf = motion.estimate(cur, ref, radius=6, precision="whole")
    full, ce = motion.estimate(cur, ref, radius=6, method="exhaustive", precision="whole")
    assert np.all(cf >= ce - 1e-9)
    inner = fast[1:-1, 1:-1, 1:-1].reshape(-1, 3)
    textured = cf[1:-1, 1:-1, 1:-1].reshape(-1) == 0
    assert textured.any()
    assert (inner[textured] == (-8, 12, -4)).all()  # cur[p] = ref[p - d]: vector -d, in quarters


def test_subvoxel_refinement_lowers_the_error():
    a = synth.translate(synth.head((24, 24, 24)), 2, step=(0.5, 0.5, -0.5), dtype=np.float64)
    costs = {}
    for prec in motion.PRECISIONS:
        v, costs[prec] = motion.estimate(a[1], a[0], radius=3, precision=prec)
    assert np.all(costs["half"] <= costs["whole"]) and np.all(costs["quarter"] <= costs["half"])
    assert costs["half"].sum() < 0.5 * costs["whole"].sum()
    v, _ = motion.estimate(a[1], a[0], radius=3, precision="half")
    vals, counts = np.unique(v.reshape(-1, 3), axis=0, return_counts=True)
    assert tuple(vals[counts.argmax()]) == (-2, -2, 2)  # half a voxel back along the motion


def test_intra_mode_where_nothing_predicts(rng):
    ref = synth.head((16, 16, 16))
    cur = ref.copy()
    cur[:8, :8, :8] = rng.integers(0, 255, (8, 8, 8))  # new content in one block
    f = motion.choose_modes(cur, ref, None, radius=2)
    assert f.mode[0, 0, 0] == motion.MODE_INTRA
    assert (f.mode.reshape(-1)[1:] == motion.MODE_FWD).all()
    assert f.counts()["intra"] == 1


def test_bad_arguments():
    a = np.zeros((8, 8, 8), np.uint8)
    with pytest.raises(ValueError, match="one shape"):
        motion.estimate(a, np.zeros((8, 8, 9), np.uint8))
    with pytest.raises(ValueError, match="search method"):
        motion.estimate(a, a, method="diamond")
    with pytest.raises(ValueError, match="precision"):
        motion.estimate(a, a, precision="eighth")
    f = motion.choose_modes(a, a, None)
    with pytest.raises(ValueError, match="compensation"):
        motion.compensate(f, a, compensation="overlapped")


@pytest.mark.parametrize("k", [0, 6, 16])
def test_smoothing_matches_the_voxel_by_voxel_filter(k):
    rng = np.random.default_rng(k)
    for shape in ((5, 7, 9), (1, 4, 3), (2, 1, 5), (3, 6, 1)):  # the ring of planes
        pred = rng.normal(100, 30, shape)
        assert np.array_equal(motion.smooth(pred, k), naive_motion.smooth(pred, k))
    # the weights sum to one: a constant passes unchanged
    assert np.allclose(motion.smooth(np.full((4, 5, 6), 7.5), k), 7.5, rtol=0, atol=1e-12)
    with pytest.raises(ValueError, match="smoothing"):
        motion.smooth(pred, 5)
