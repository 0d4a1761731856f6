"""Fixed-point positions and integer trilinear sampling (volpack.render.fixed) against a
float64 trilinear reference, on every voxel dtype the fast march samples, including
positions in the clamped shell outside [0, n - 1]."""

from __future__ import annotations

import numpy as np
import pytest

from volpack.render.fixed import FRAC, interior, to_fixed, trilinear_fixed, trilinear_inner, value_unit


def reference(vol, z, y, x) -> float:
    """Trilinear sample in float64, positions clamped to the volume."""
    out = 0.0
    idx = []
    for p, n in zip((z, y, x), vol.shape):
        q = min(max(p, 0.0), n - 1.0)
        i = int(q)
        idx.append((i, min(i + 1, n - 1), q - i))
    (z0, z1, fz), (y0, y1, fy), (x0, x1, fx) = idx
    for zi, wz in ((z0, 1 - fz), (z1, fz)):
        for yi, wy in ((y0, 1 - fy), (y1, fy)):
            for xi, wx in ((x0, 1 - fx), (x1, fx)):
                out += wz * wy * wx * float(vol[zi, yi, xi])
    return out


@pytest.mark.parametrize("dtype", [np.uint8, np.int8, np.uint16, np.int16, np.float32])
def test_fixed_sample_matches_float_trilinear(dtype):
    rng = np.random.default_rng(1)
    info = np.iinfo(dtype) if np.issubdtype(dtype, np.integer) else None
    shape = (5, 1, 7)  # one axis one voxel thick
    if info is not None:
        vol = rng.integers(info.min, int(info.max) + 1, size=shape).astype(dtype)
    else:
        vol = (rng.normal(size=shape) * 1e3).astype(dtype)
    span = float(vol.max()) - float(vol.min())
    unit = value_unit(vol)
    pts = rng.uniform(-0.5, np.array(shape) - 0.5, size=(400, 3))
    pts[:8] = [[-0.5, -0.5, -0.5], [4.5, 0.5, 6.5], [0, 0, 0], [4, 0, 6], [2, 0, 3],
               [1.999999, 0, 5.000001], [3.5, 0.25, -0.25], [4.25, 0, 6.25]]  # fmt: skip
    for z, y, x in pts:
        got = trilinear_fixed(vol, 0, to_fixed(z), to_fixed(y), to_fixed(x)) / unit
        # weights of 2^-20, positions rounded to 2^-25, three floored shifts
        tol = span * 4e-6 + (4.0 / (1 << 20) if info is not None else 1e-6 * abs(got))
        assert abs(got - reference(vol, z, y, x)) <= tol, (dtype, z, y, x)


def test_to_fixed_rounds_and_steps_exactly():
    assert to_fixed(1.5) == 3 << (FRAC - 1)
    assert to_fixed(-0.5) == -(1 << (FRAC - 1))
    # a segment end is base + k * stride: exact integers, within k 2^-25 voxel of float
    base, stride = to_fixed(-0.5), to_fixed(0.37)
    for k in (1, 10, 1000):
        assert abs((base + k * stride) / (1 << FRAC) - (-0.5 + k * 0.37)) <= k * 2.0 ** -25


def test_interior_steps_are_exactly_those_inside():
    """``interior(b, s, n)``: the steps k whose position b + k s lies in [0, n - 1),
    against a walk over k, at strides of both signs, zero, and ends on the boundary."""
    rng = np.random.default_rng(3)
    one = 1 << FRAC
    n = 6
    cases = [(0, 0), (-1, 0), ((n - 1) * one, 0), ((n - 1) * one - 1, 0), (0, one // 2),
             (-one // 2, one // 2), ((n - 1) * one, -one // 2), ((n - 1) * one - 1, -one // 3),
             (-1, 1 << (FRAC - 1)), (n * one, -(one // 2) - 1)]  # fmt: skip
    cases += [(int(rng.integers(-2 * one, (n + 1) * one)),
               int(rng.integers(-one, one))) for _ in range(200)]  # fmt: skip
    for b, s in cases:
        lo, hi = interior(np.int64(b), np.int64(s), n)
        ks = range(-40, 41) if s else range(-2, 3)
        inside = [k for k in ks if 0 <= b + k * s < (n - 1) * one]
        got = [k for k in ks if lo <= k <= hi]
        assert got == inside, (b, s, lo, hi)


@pytest.mark.parametrize("dtype", [np.uint8, np.float32])
def test_inner_sample_equals_the_clamped_one_inside(dtype):
    """Inside [0, n - 1) the unclamped sampler gives the clamped one's value exactly."""
    rng = np.random.default_rng(4)
    shape = (4, 5, 6)
    vol = (rng.integers(0, 256, size=shape) if dtype == np.uint8
           else rng.normal(size=shape) * 1e3).astype(dtype)  # fmt: skip
    top = (np.array(shape) - 1) * (1 << FRAC) - 1
    pts = rng.integers(0, top + 1, size=(300, 3))
    pts[:2] = [[0, 0, 0], top]
    for pz, py, px in pts:
        p = np.int64(pz), np.int64(py), np.int64(px)
        assert trilinear_inner(vol, *p) == trilinear_fixed(vol, 0, *p)
