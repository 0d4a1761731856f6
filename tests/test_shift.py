"""Whole-frame shifts: the transform against a direct convolution, the kernel, the
vector estimate on a known translation, and the rounding guard."""

from __future__ import annotations

import numpy as np
import pytest
from naive_motion import whole_frame_shift

from volpack import synth
from volpack.animation import shift

# slow: animation kernels: long to compile (pytest -m slow runs them; .ci/run does)
pytestmark = pytest.mark.slow


def _smooth(n):
    for p in (3, 5, 7, 11):
        while n % p == 0:
            n //= p
    return n == 1


@pytest.mark.parametrize("n", [1, 2, 16, 17, 64, 100, 128])
def test_padded_length_is_the_least_odd_smooth_length(n):
    m = shift.padded_length(n)
    assert m % 2 == 1 and _smooth(m) and m >= n + 2 * shift.PAD
    assert not any(_smooth(k) for k in range(n + 2 * shift.PAD, m, 1) if k % 2)


def test_kernel_taps():
    h = shift.kernel_taps(0.0)
    assert h.size == 2 * shift.TAPS and np.isclose(h.sum(), 1.0)
    assert np.allclose(h, np.eye(1, h.size, shift.TAPS - 1).ravel(), atol=1e-15)  # a delta
    half = shift.kernel_taps(0.5)
    assert np.allclose(half, half[::-1])  # midway: symmetric about the two neighbours


@pytest.mark.parametrize(
    "v", [(0, 0, 0), (1, -2, 3), (0.5, 0.25, -0.75), (-1.3, 2.7, 0.015625), (6.5, 0, -9.25)]
)
def test_shift_matches_a_direct_convolution(v):
    rng = np.random.default_rng(3)
    frame = rng.integers(0, 256, (10, 13, 17)).astype(np.uint8)
    got = shift.shifted([(shift.spectrum(frame), np.array(v, float), 1.0)], frame.shape)
    want = whole_frame_shift(frame, v)
    assert np.abs(got - want).max() < 1e-9
    if all(float(d).is_integer() for d in v):  # whole vectors move voxels exactly
        vz, vy, vx = (int(d) for d in v)
        inner = frame[max(vz, 0) : 10 + min(vz, 0), max(vy, 0) : 13 + min(vy, 0), max(vx, 0) :]
        inner = inner[:, :, : 17 - max(vx, 0) + min(vx, 0)]
        part = got[max(-vz, 0) :, max(-vy, 0) :, max(-vx, 0) :][
            : inner.shape[0], : inner.shape[1], : inner.shape[2]
        ]
        assert np.abs(part - inner).max() < 1e-9


def test_weighted_terms_add():
    rng = np.random.default_rng(4)
    a, b = (rng.normal(size=(9, 11, 12)) for _ in range(2))
    va, vb = np.array([0.5, -0.25, 1.0]), np.array([-1.5, 0.75, 0.0])
    got = shift.shifted([(shift.spectrum(a), va, 0.5), (shift.spectrum(b), vb, 0.5)], a.shape)
    want = 0.5 * whole_frame_shift(a, va) + 0.5 * whole_frame_shift(b, vb)
    assert np.abs(got - want).max() < 1e-9


@pytest.mark.parametrize("step", [(0.5, 0.25, 0.75), (0.3, -0.6, 1.375), (-1.0, 0.0, 2.5)])
def test_estimate_recovers_a_translation(step):
    frames = synth.translate(synth.head((40, 44, 48)), 3, step=step, crop=(24, 28, 32))
    ref = shift.spectrum(frames[0])
    for t in (1, 2):
        want = -t * np.asarray(step)
        start = np.round(want * 4) / 4 + 0.25  # a quarter voxel off, as blocks might say
        got = shift.estimate(frames[t], ref, start, 15.75)
        assert np.abs(got - want).max() <= 1 / 64 + 1e-12, (t, got, want)


def test_ambiguous_flags_only_values_near_a_half():
    peak = 255.0
    g = shift.GUARD * (1 + peak)
    pred = np.array([3.5, 3.5 + 0.5 * g, 3.5 - 0.9 * g, 3.5 + 2 * g, 4.0, -2.5, 7.49, 0.5])
    assert shift.ambiguous(pred, peak).tolist() == [0, 1, 2, 5, 7]
