"""Test animations with known motion, for tests and benchmarks.

Each generator returns a ``(t, z, y, x)`` array. Motion is applied by sampling a source
volume (by default a crop of the bundled head MRI) with trilinear interpolation at moved
positions, clamped at the border, so sub-voxel steps are real sub-voxel motion. The
defaults are small so tests stay fast.
"""

from __future__ import annotations

import numpy as np

from .errors import OptionError

DEFAULT_SHAPE = (32, 32, 32)


def head(shape: tuple[int, int, int] = DEFAULT_SHAPE) -> np.ndarray:
    """A centred crop of the bundled head MRI (uint8)."""
    from .demo import load_demo_volume

    v = load_demo_volume().data
    if any(s > n for s, n in zip(shape, v.shape)):
        raise OptionError(f"expected a crop within {v.shape}, found {shape}")
    lo = [(n - s) // 2 for s, n in zip(shape, v.shape)]
    return np.ascontiguousarray(v[tuple(slice(a, a + s) for a, s in zip(lo, shape))])


def sample(vol: np.ndarray, z, y, x) -> np.ndarray:
    """Trilinear samples of ``vol`` at float coordinates (clamped to the volume)."""
    vol = np.asarray(vol, np.float64)
    coords = []
    for c, n in zip((z, y, x), vol.shape):
        c = np.clip(np.asarray(c, np.float64), 0, n - 1)
        i0 = np.minimum(np.floor(c).astype(np.int64), max(n - 2, 0))
        coords.append((i0, c - i0, np.minimum(i0 + 1, n - 1)))
    out = 0.0
    for a in (0, 1):
        for b in (0, 1):
            for d in (0, 1):
                w = 1.0
                idx = []
                for (i0, f, i1), bit in zip(coords, (a, b, d)):
                    w = w * (f if bit else 1 - f)
                    idx.append(i1 if bit else i0)
                out = out + w * vol[tuple(idx)]
    return out


def _as(vals: np.ndarray, dtype) -> np.ndarray:
    dtype = np.dtype(dtype)
    if dtype.kind in "iu":
        info = np.iinfo(dtype)
        return np.clip(np.rint(vals), info.min, info.max).astype(dtype)
    return vals.astype(dtype)


def translate(
    vol: np.ndarray | None = None,
    frames: int = 8,
    step: tuple[float, float, float] = (0.5, 0.25, 0.75),
    dtype=np.uint8,
    crop: tuple[int, int, int] | None = None,
) -> np.ndarray:
    """``vol`` moving by ``step`` voxels per frame along ``(z, y, x)``: frame ``t`` at
    position ``p`` shows the source at ``p - t * step``. With ``crop`` the frames show
    the centred ``crop`` of the moving volume, so content from outside enters the view
    as it would a scanner's field of view (without it, what enters is the reflection the
    volume is padded with).

    The shift is band-limited (a phase ramp in the Fourier domain, on the volume padded
    by reflection), so a sub-voxel step moves the content without blurring it, as a
    scanner would see an object that moved; interpolating instead would blur every frame
    by a different amount. The padded lengths are odd: an even length has a Nyquist
    frequency, which a real frame cannot move (its phase factor would be complex), so
    that component would fade as ``cos(pi t step)`` and frames would blur after all.
    """
    vol = head() if vol is None else np.asarray(vol)
    reach = int(np.ceil(np.abs(np.asarray(step)).max() * max(frames - 1, 0))) + 8
    pad = [min(reach, n - 1) for n in vol.shape]
    widths = [(p, p + 1 - (n + 2 * p) % 2) for p, n in zip(pad, vol.shape)]
    big = np.pad(vol.astype(np.float64), widths, mode="reflect")
    spec = np.fft.rfftn(big)
    freqs = [np.fft.fftfreq(n) for n in big.shape[:2]] + [np.fft.rfftfreq(big.shape[2])]
    k = np.meshgrid(*freqs, indexing="ij", sparse=True)
    if crop is None:
        crop = vol.shape
    if len(crop) != 3 or any(not 0 < c <= n for c, n in zip(crop, vol.shape)):
        raise OptionError(f"expected a crop within {vol.shape}, found {crop}")
    lo = [p + (n - c) // 2 for p, n, c in zip(pad, vol.shape, crop)]
    view = tuple(slice(a, a + c) for a, c in zip(lo, crop))
    out = []
    for t in range(frames):
        phase = sum(k[a] * (t * step[a]) for a in range(3))
        out.append(
            np.fft.irfftn(spec * np.exp(-2j * np.pi * phase), big.shape, axes=(0, 1, 2))[view]
        )
    return _as(np.stack(out), dtype)


def rotate(
    vol: np.ndarray | None = None, frames: int = 8, degrees: float = 2.0, dtype=np.uint8
) -> np.ndarray:
    """``vol`` turning about its z axis (through the centre) by ``degrees`` per frame."""
    vol = head() if vol is None else np.asarray(vol)
    z, y, x = np.indices(vol.shape, dtype=np.float64)
    cy, cx = (vol.shape[1] - 1) / 2, (vol.shape[2] - 1) / 2
    out = []
    for t in range(frames):
        a = np.deg2rad(degrees * t)
        c, s = np.cos(a), np.sin(a)
        yy, xx = y - cy, x - cx
        out.append(sample(vol, z, cy + c * yy + s * xx, cx - s * yy + c * xx))
    return _as(np.stack(out), dtype)


def blob(
    shape: tuple[int, int, int] = DEFAULT_SHAPE,
    frames: int = 8,
    grow: float = 0.75,
    dtype=np.uint8,
) -> np.ndarray:
    """A soft sphere whose radius grows by ``grow`` voxels per frame."""
    g = np.indices(shape, dtype=np.float64)
    r = np.sqrt(sum((g[a] - (shape[a] - 1) / 2) ** 2 for a in range(3)))
    out = [200.0 / (1 + np.exp((r - (3 + grow * t)) / 1.2)) + 20 for t in range(frames)]
    return _as(np.stack(out), dtype)


def advect(
    shape: tuple[int, int, int] = DEFAULT_SHAPE,
    frames: int = 8,
    speed: float = 0.6,
    seed: int = 0,
    dtype=np.uint8,
) -> np.ndarray:
    """A smooth random field carried by a smooth swirling flow (semi-Lagrangian steps
    of up to ``speed`` voxels per frame)."""
    rng = np.random.default_rng(seed)
    g = np.indices(shape, dtype=np.float64)
    k = [2 * np.pi / n for n in shape]
    field = 128.0
    for _ in range(6):
        f = rng.uniform(0.5, 2.5, 3)
        ph = rng.uniform(0, 2 * np.pi, 3)
        field = field + 20 * np.prod([np.sin(f[a] * k[a] * g[a] + ph[a]) for a in range(3)], 0)
    field = field + 30 * np.sin(3 * k[2] * g[2]) * np.cos(2 * k[1] * g[1])
    # a divergence-free swirl in (y, x) that varies with z, plus a slow drift along z
    vz = 0.3 * speed * np.ones(shape)
    vy = speed * np.sin(k[2] * g[2]) * np.cos(k[0] * g[0] / 2)
    vx = speed * np.sin(k[1] * g[1])
    out = [field]
    for _ in range(frames - 1):
        field = sample(field, g[0] - vz, g[1] - vy, g[2] - vx)
        out.append(field)
    return _as(np.stack(out), dtype)


def scene_cut(first: np.ndarray, second: np.ndarray, cut: int | None = None) -> np.ndarray:
    """Frames of ``first`` up to ``cut``, then frames of ``second``."""
    if first.shape[1:] != second.shape[1:] or first.dtype != second.dtype:
        raise OptionError(
            f"expected animations of one frame shape and dtype, found {first.shape} "
            f"{first.dtype} and {second.shape} {second.dtype}"
        )
    cut = first.shape[0] // 2 if cut is None else cut
    return np.concatenate([first[:cut], second[cut:]])


def noise(
    shape: tuple[int, int, int] = DEFAULT_SHAPE, frames: int = 4, seed: int = 0, dtype=np.uint8
) -> np.ndarray:
    """Independent uniform noise in every frame: nothing to predict."""
    rng = np.random.default_rng(seed)
    return _as(rng.uniform(0, 255, (frames, *shape)), dtype)


GENERATORS = {
    "translate": translate,
    "rotate": rotate,
    "blob": blob,
    "advect": advect,
}
