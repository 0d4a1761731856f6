"""More analogs of the public benchmark sets (Open SciVis, SDRBench) of kinds no earlier
trial had; seeded.

Run: PYTHONPATH=. python results/kinds38/make.py DIR [NAME ...]
Writes DIR/<name>.npy and DIR/volumes.txt (name, int|float, set, shape, dtype).
Held out (named before any run, HELDOUT.md): carp_u16, bunny_u16, mra_u16, heptane_u8,
reconn_bx, letkf_qv.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
from scipy import ndimage

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "scripts"))

from datasets import load  # noqa: E402
from trialkit import write_volumes  # noqa: E402

HELD_OUT = ("carp_u16", "bunny_u16", "mra_u16", "heptane_u8", "reconn_bx", "letkf_qv")


def grid(shape, lo=0.0, hi=1.0):
    return np.meshgrid(*(np.linspace(lo, hi, n) for n in shape), indexing="ij")


def gauss_field(rng, shape, slope, stretch=(1.0, 1.0, 1.0)):
    """A Gaussian random field of unit variance with power spectrum k^slope (periodic);
    `stretch` > 1 along an axis makes it correlated longer along that axis."""
    ks = [np.fft.fftfreq(n) * s for n, s in zip(shape, stretch)]
    kk = np.sqrt(sum(k**2 for k in np.meshgrid(*ks, indexing="ij")))
    kk.flat[0] = 1.0
    g = np.fft.ifftn(np.fft.fftn(rng.normal(size=shape)) * kk ** (slope / 2)).real
    return (g - g.mean()) / g.std()


def tubes(shape, paths, radius):
    """A mask of tubes of `radius` voxels along polylines given in unit coordinates."""
    m = np.zeros(shape, bool)
    for pts in paths:
        idx = np.rint(np.asarray(pts) * (np.array(shape) - 1)).astype(int)
        idx = idx[np.all((idx >= 0) & (idx < np.array(shape)), axis=1)]
        m[tuple(idx.T)] = True
    if radius > 0:
        m = ndimage.binary_dilation(m, iterations=radius)
    return m


def walk_tree(rng, start, d, n, step, depth, branch_p, out):
    """A random-walk vessel / branch tree in unit coordinates: lists of points."""
    pts = [np.array(start, float)]
    d = np.asarray(d, float)
    for _ in range(n):
        d = d + rng.normal(scale=0.15, size=3)
        d /= np.linalg.norm(d)
        pts.append(pts[-1] + step * d)
        if depth < 4 and rng.random() < branch_p:
            walk_tree(rng, pts[-1], d + rng.normal(scale=0.9, size=3), n // 2, step,
                      depth + 1, branch_p, out)  # fmt: skip
    out.append((depth, np.array(pts)))
    return out


# ---------------------------------------------------------------- integer volumes


def fuel_u8(rng):
    """Open SciVis fuel injection (64^3 uint8, mostly zero): a round turbulent jet from a
    nozzle, concentration ~ 1/z on the axis, Gaussian across a linearly growing width,
    wrinkled by turbulence; below 1.5 / 255 it is exactly 0."""
    shape = (64, 64, 64)
    z, y, x = grid(shape)
    g = gauss_field(rng, shape, -3.5)
    w = 0.03 + 0.16 * z
    r2 = (y - 0.5 - 0.03 * g * z) ** 2 + (x - 0.5 + 0.03 * g * z) ** 2
    c = 0.12 / (z + 0.12) * np.exp(-r2 / w**2) * (1 + 0.35 * g * np.sqrt(z))
    v = np.rint(255 * np.clip(c, 0, 1))
    v[v < 2] = 0
    return v.astype(np.uint8)


def lobster_u8(rng):
    """Open SciVis lobster (thin CT slices, uint8): a body of segments and two claws in a
    narrow band (shell ~70, flesh ~45) over a noise floor of 0..14 everywhere."""
    shape = (56, 160, 150)
    z, y, x = grid(shape)
    v = np.zeros(shape)
    d = np.full(shape, 9.0)
    for k in range(7):  # tail segments along y
        cy = 0.25 + 0.08 * k
        e = ((z - 0.5) / 0.3) ** 2 + ((y - cy) / 0.05) ** 2 + ((x - 0.5) / (0.16 - 0.01 * k)) ** 2
        d = np.minimum(d, e)
    for s in (-1, 1):  # claws: arms and pincers
        e = ((z - 0.5) / 0.2) ** 2 + ((y - 0.15) / 0.12) ** 2 + ((x - 0.5 - s * 0.27) / 0.1) ** 2
        d = np.minimum(d, e)
    body = d < 1
    shell = body & (d > 0.75)
    v[body] = 45.0 + 3.0 * gauss_field(rng, shape, -3.0)[body]
    v[shell] = 70.0
    v = ndimage.gaussian_filter(v, 0.7)
    v += rng.integers(0, 15, size=shape)  # the noise floor
    return np.clip(np.rint(v), 0, 255).astype(np.uint8)


def _ct_object(rng, shape, parts, air=40.0, sigma=28.0, blur=0.8, bits=12):
    """A CT of an object in air: `parts` (mask, value) painted in order, blurred, noise
    that grows with the signal, 12 bits in uint16."""
    v = np.full(shape, air)
    for m, val in parts:
        v[m] = val
    v = ndimage.gaussian_filter(v, blur)
    v += rng.normal(size=shape) * sigma * np.sqrt(v / 1000.0 + 0.2)
    return np.clip(np.rint(v), 0, 2**bits - 1).astype(np.uint16)


def tooth_u16(rng):
    """Open SciVis tooth (uint16 CT, 12 bits, lots of air): an enamel cap (~3100) over
    dentin (~1900) around a pulp canal (~500), two roots, air ~40 with noise."""
    shape = (128, 80, 96)
    z, y, x = grid(shape)
    crown = ((z - 0.3) / 0.22) ** 2 + ((y - 0.5) / 0.33) ** 2 + ((x - 0.5) / 0.36) ** 2
    tooth = crown < 1
    roots = np.zeros(shape, bool)
    for s in (-1, 1):
        cx = 0.5 + s * (0.14 + 0.1 * (z - 0.4))
        roots |= (
            (z > 0.35)
            & (z < 0.92)
            & (((y - 0.5) / 0.18) ** 2 + ((x - cx) / 0.1) ** 2 < (1 - (z - 0.35) / 0.6))
        )
    tooth |= roots
    enamel = tooth & (crown > 0.7) & (z < 0.32)
    pulp = ndimage.binary_erosion(tooth, iterations=6)
    pulp = ndimage.binary_erosion(pulp, iterations=4) | (
        pulp & (((y - 0.5) / 0.06) ** 2 + ((x - 0.5) / 0.06) ** 2 < 1) & (z > 0.3)
    )
    return _ct_object(rng, shape, [(tooth, 1900.0), (enamel, 3100.0), (pulp, 500.0)])


def carp_u16(rng):
    """Open SciVis carp (uint16 CT, 12 bits): a fish body (~1100) with a spine of
    vertebrae and thin ribs (~2600), a swim bladder (air), fins, in air."""
    shape = (80, 96, 192)
    z, y, x = grid(shape)
    t = np.clip((x - 0.08) / 0.84, 0, 1)
    half = 0.28 * np.sin(np.pi * t) ** 0.7 + 1e-3
    body = (x > 0.08) & (x < 0.92) & (((z - 0.5) / (0.7 * half)) ** 2 + ((y - 0.5) / half) ** 2 < 1)
    bladder = (((z - 0.5) / 0.08) ** 2 + ((y - 0.55) / 0.1) ** 2 + ((x - 0.45) / 0.15) ** 2) < 1
    spine = np.zeros(shape, bool)
    for k in range(22):  # vertebrae
        cx = 0.15 + 0.033 * k
        spine |= ((z - 0.5) / 0.025) ** 2 + ((y - 0.42) / 0.025) ** 2 + ((x - cx) / 0.012) ** 2 < 1
    paths = []
    for k in range(14):  # ribs
        cx = 0.3 + 0.025 * k
        s = np.linspace(0, 1, 200)
        for side in (-1, 1):
            paths.append(
                np.stack(
                    [0.5 + side * 0.18 * np.sin(2.2 * s), 0.42 + 0.2 * s**1.5, cx + 0.03 * s], 1
                )
            )
    ribs = tubes(shape, paths, 0)
    fin = (
        (x > 0.86)
        & (x < 0.99)
        & (np.abs(z - 0.5) < 0.015)
        & (np.abs(y - 0.5) < 0.25 * (x - 0.86) / 0.13 + 0.02)
    )
    return _ct_object(
        rng, shape, [(body | fin, 1100.0), (bladder & body, 60.0), (spine, 2600.0), (ribs, 2400.0)]
    )


def bunny_u16(rng):
    """Open SciVis bunny (a hollow ceramic figure, uint16 CT, 12 bits): a closed shell
    three voxels thick around an irregular blob (a smoothed random isosurface) in a box of
    air larger than it."""
    shape = (112, 112, 112)
    z, y, x = grid(shape, -1, 1)
    r = np.sqrt(z**2 + y**2 + x**2)
    f = r - 0.55 - 0.12 * gauss_field(rng, shape, -4.5)
    ears = np.minimum(
        np.hypot(z + 0.55 + 0.2 * (y - 0.1) ** 2, x - 0.15),
        np.hypot(z + 0.55 + 0.2 * (y - 0.1) ** 2, x + 0.15),
    )
    f = np.minimum(f, np.maximum(ears - 0.08, np.abs(y - 0.25) - 0.4))
    solid = f < 0
    inner = ndimage.binary_erosion(solid, iterations=3)
    return _ct_object(rng, shape, [(solid, 2700.0), (inner, 40.0)], sigma=22.0)


def stent_u16(rng):
    """Open SciVis stent (uint16 CT angiography): soft tissue ~1040 with noise, a vessel
    along z filled with contrast (~1400), a metal stent as two crossing helices of thin
    wire (~3800) in its wall, a bone at the side (~1800); body in air (0)."""
    shape = (96, 128, 128)
    z, y, x = grid(shape)
    body = ((y - 0.5) / 0.46) ** 2 + ((x - 0.5) / 0.48) ** 2 < 1
    cy, cx = 0.45 + 0.05 * np.sin(3 * z), 0.5 + 0.04 * np.cos(2 * z)
    lumen = (y - cy) ** 2 + (x - cx) ** 2 < 0.09**2
    bone = ((y - 0.72) / 0.08) ** 2 + ((x - 0.3) / 0.1) ** 2 < 1
    s = np.linspace(0, 1, 4000)
    paths = []
    for k in range(6):
        for hand in (-1, 1):
            th = hand * 2 * np.pi * 3 * s + 2 * np.pi * k / 6
            zz = 0.15 + 0.7 * s
            paths.append(np.stack([zz, 0.45 + 0.05 * np.sin(3 * zz) + 0.095 * np.sin(th),
                                   0.5 + 0.04 * np.cos(2 * zz) + 0.095 * np.cos(th)], 1))  # fmt: skip
    wire = tubes(shape, paths, 0)
    v = np.where(body, 1040.0, 0.0)
    v[lumen] = 1400.0
    v[bone] = 1800.0
    v = ndimage.gaussian_filter(v, 0.8)
    v[wire] = 3800.0
    v = ndimage.gaussian_filter(v, 0.4)
    v += np.where(body, rng.normal(size=shape) * 18.0, rng.normal(size=shape) * 2.0)
    return np.clip(np.rint(v), 0, 65535).astype(np.uint16)


def mra_u16(rng):
    """Open SciVis MR angiography (uint16): bright thin vessels (a tree of random walks,
    radius 0..2 voxels, ~900) on dim tissue (~120) under Rician noise (sigma 25): the
    background is the magnitude of complex Gaussian noise."""
    shape = (64, 160, 160)
    trees = []
    for k in range(4):
        walk_tree(rng, (0.05, 0.3 + 0.13 * k, 0.5), (1, 0.1, 0.0), 60, 0.02, 0, 0.08, trees)
    v = np.zeros(shape)
    z, y, x = grid(shape)
    v += 120.0 * (((y - 0.5) / 0.45) ** 2 + ((x - 0.5) / 0.45) ** 2 < 1)
    for depth, pts in trees:
        m = tubes(shape, [pts], max(0, 2 - depth))
        v[m] = 900.0 - 120 * depth
    v = ndimage.gaussian_filter(v, 0.6)
    re = v + rng.normal(size=shape) * 25.0
    im = rng.normal(size=shape) * 25.0
    return np.clip(np.rint(np.hypot(re, im)), 0, 65535).astype(np.uint16)


def frog_u8(rng):
    """Open SciVis frog (thin-slice uint8 MRI, 44 slices): the corpus's segmented frog
    (frog_labels, 136 x 470 x 500) cut to 44 slices and every second pixel, each tissue
    given an MR intensity, blurred in-plane, Rician-like noise."""
    a, _, _ = load("frog_labels")
    zi = np.rint(np.linspace(0, a.shape[0] - 1, 44)).astype(int)
    lab = a[zi, ::2, ::2]
    table = rng.uniform(30, 220, size=int(lab.max()) + 1)
    table[0] = 6.0
    v = table[lab]
    v = ndimage.gaussian_filter(v, (0.3, 0.9, 0.9))
    v = np.hypot(v + rng.normal(size=v.shape) * 5.0, rng.normal(size=v.shape) * 5.0)
    return np.clip(np.rint(v), 0, 255).astype(np.uint8)


def heptane_u8(rng):
    """Open SciVis heptane (a combustion temperature quantised to uint8, 302^3 there):
    a lifted turbulent flame, cold fuel jet (~20) inside a hot wrinkled flame zone
    (~230) over a warm coflow (~90); 96^3, no noise."""
    shape = (96, 96, 96)
    z, y, x = grid(shape)
    g = gauss_field(rng, shape, -3.6)
    r = np.hypot(y - 0.5, x - 0.5) + 0.04 * g
    w = 0.08 + 0.25 * z
    jet = np.exp(-((r / w) ** 2))
    flame = np.exp(-(((r - 0.9 * w) / (0.03 + 0.05 * z)) ** 2)) * np.clip((z - 0.12) / 0.15, 0, 1)
    t = 90 - 70 * jet + 150 * flame * (1 + 0.15 * gauss_field(rng, shape, -3.0))
    return np.clip(np.rint(t), 0, 255).astype(np.uint8)


def shock_u8(rng):
    """A shock wave in a long channel (64 x 64 x 512, uint8): a curved front two-thirds of
    the way along x, 40 ahead of it and ~200 behind with decaying post-shock oscillations,
    a boundary layer at the walls, weak turbulence behind the front."""
    shape = (64, 64, 512)
    z, y, x = grid(shape)
    front = 0.66 - 0.04 * ((y - 0.5) ** 2 + (z - 0.5) ** 2) * 4
    s = (front - x) * 512
    behind = 0.5 * (1 + np.tanh(s / 1.5))
    osc = np.where(s > 0, 12 * np.cos(s / 7) * np.exp(-s / 60), 0)
    wall = np.minimum(np.minimum(y, 1 - y), np.minimum(z, 1 - z))
    bl = 1 - np.exp(-wall / 0.06)
    v = 40 + (160 + osc) * behind * bl
    v += behind * 6 * gauss_field(rng, shape, -3.2, (1, 1, 0.5))
    return np.clip(np.rint(v), 0, 255).astype(np.uint8)


def _exafel(rng, n=24, size=128, parts=None):
    """EXAFEL-like detector frames (x-ray free-electron laser shots): photons per pixel
    (Poisson) of a diffuse ring plus Bragg spots that move from shot to shot, times a
    gain of 30 ADU, read noise 3 ADU after dark subtraction; 2 x 2 panels with gaps of 0;
    0.4 % dead pixels (0) and 0.05 % hot pixels (saturated 16383) fixed over the stack.
    ``parts``, a dict, gets the photon rates ``lam`` (n, size, size) and the pixels that
    are live (noise_bound.py)."""
    yy, xx = np.meshgrid(
        np.arange(size) - size / 2 + 0.5, np.arange(size) - size / 2 + 0.5, indexing="ij"
    )
    r = np.hypot(yy, xx)
    ring = 0.08 + 0.6 * np.exp(-(((r - 38) / 6) ** 2)) + 0.3 / (1 + r / 10)
    frames = np.empty((n, size, size))
    lams = np.empty((n, size, size))
    for i in range(n):
        lam = ring.copy()
        for _ in range(40):
            py, px = rng.uniform(0, size, 2)
            lam += rng.exponential(60) * np.exp(
                -((yy + size / 2 - py) ** 2 + (xx + size / 2 - px) ** 2) / 1.2
            )
        frames[i] = rng.poisson(lam) * 30.0 + rng.normal(size=lam.shape) * 3.0
        lams[i] = lam
    gap = np.zeros((size, size), bool)
    gap[size // 2 - 2 : size // 2 + 2] = True
    gap[:, size // 2 - 2 : size // 2 + 2] = True
    dead = rng.random((size, size)) < 0.004
    hot = rng.random((size, size)) < 0.0005
    frames[:, gap | dead] = 0.0
    frames[:, hot] = 16383.0
    if parts is not None:
        parts.update(lam=lams, live=~(gap | dead | hot))
    return frames


def exafel_i16(rng):
    """EXAFEL-like detector frames as int16 ADU (24 shots of 128 x 128; see _exafel)."""
    return np.clip(np.rint(_exafel(rng)), -32768, 32767).astype(np.int16)


# ---------------------------------------------------------------- float fields


def duct_u(rng):
    """A turbulent square-duct flow's streamwise velocity (float32, 40 x 40 x 1000, long
    along x as the public duct set is): a laminar-like profile that is zero at the walls,
    turbulent streaks correlated ~8x longer along x than across."""
    shape = (40, 40, 1000)
    z, y, _ = grid(shape)
    prof = (1 - (2 * z - 1) ** 8) * (1 - (2 * y - 1) ** 8)
    g = gauss_field(rng, shape, -3.4, (1, 1, 8))
    return (prof * (1.0 + 0.12 * g)).astype(np.float32)


def _reconnection(rng, shape=(96, 96, 128)):
    """A double Harris current sheet with a chain of plasmoids (flux function psi), kinked
    along y; returns (current density J_y, B_x)."""
    z, y, x = grid(shape)
    d = 0.018
    kink = 0.02 * np.sin(2 * np.pi * (2 * y + 0.3))
    psi = np.zeros(shape)
    for z0, sgn in ((0.25, 1), (0.75, -1)):
        zz = z - z0 - kink
        psi += sgn * d * np.log(np.cosh(zz / d))
        for k in range(1, 6):
            a = rng.uniform(0.2, 1.0) * d / k
            psi += (
                sgn
                * a
                * np.cos(2 * np.pi * (k * 3 * x + rng.random()))
                * np.exp(-((zz / (4 * d)) ** 2))
            )
    psi += 0.002 * gauss_field(rng, shape, -4.0)
    h = [1.0 / (n - 1) for n in shape]
    bx = np.gradient(psi, h[0], axis=0)
    j = -sum(np.gradient(np.gradient(psi, h[k], axis=k), h[k], axis=k) for k in range(3))
    return j.astype(np.float32), bx.astype(np.float32)


def reconn_j(rng):
    """Magnetic reconnection's current density (float32, 96 x 96 x 128): two thin current
    sheets (~2 voxels) broken into plasmoids, near zero elsewhere."""
    return _reconnection(rng)[0]


def reconn_bx(rng):
    """Magnetic reconnection's B_x (float32): the same kind of field as reconn_j, its
    in-plane field: a tanh jump across each sheet with island loops."""
    return _reconnection(rng)[1]


def _letkf(rng, shape=(98, 128, 160)):
    """A SCALE-LETKF-like grid: 98 thin vertical levels over terrain; levels below the
    ground hold the model's undefined value -9.9999e30."""
    lev = np.arange(shape[0])[:, None, None]
    hgt = 1.2 * (lev + 0.02 * lev**2)  # level heights in 100 m, thin near the ground
    ter = 10 * np.clip(gauss_field(rng, shape[1:] + (1,), -4.5)[..., 0] + 0.5, 0, None)
    return hgt, ter[None], lev


def letkf_t(rng):
    """SCALE-LETKF temperature (K, float32, 98 x 128 x 160): a lapse rate of 6.5 K/km to
    the tropopause then isothermal, mesoscale anomalies of +-2 K, fill below terrain."""
    hgt, ter, _ = _letkf(rng)
    shape = (98, 128, 160)
    t = 300 - 0.65 * np.minimum(hgt, 120) + 2.0 * gauss_field(rng, shape, -3.5, (3, 1, 1))
    t[np.broadcast_to(hgt < ter, shape)] = -9.9999e30
    return t.astype(np.float32)


def letkf_qv(rng):
    """SCALE-LETKF water vapour mixing ratio (kg/kg, float32): ~0.018 at the ground,
    falling off by e every 2.5 km to ~1e-6 aloft, moist and dry patches (log-normal),
    fill below terrain."""
    hgt, ter, _ = _letkf(rng)
    shape = (98, 128, 160)
    q = 0.018 * np.exp(-hgt / 25) * np.exp(0.5 * gauss_field(rng, shape, -3.5, (3, 1, 1)))
    q = np.maximum(q, 1e-6)
    q[np.broadcast_to(hgt < ter, shape)] = -9.9999e30
    return q.astype(np.float32)


def exafel_f32(rng):
    """SDRBench EXAFEL-like frames as float32 photons (calibrated: ADU / gain), the same
    hot pixels, dead pixels and panel gaps as exafel_i16's kind (24 x 128 x 128)."""
    return (_exafel(rng) / 30.0).astype(np.float32)


MAKERS = {
    f.__name__: f
    for f in (
        fuel_u8,
        lobster_u8,
        tooth_u16,
        carp_u16,
        bunny_u16,
        stent_u16,
        mra_u16,
        frog_u8,
        heptane_u8,
        shock_u8,
        exafel_i16,
        duct_u,
        reconn_j,
        reconn_bx,
        letkf_t,
        letkf_qv,
        exafel_f32,
    )  # fmt: skip
}


def main() -> None:
    write_volumes(MAKERS, HELD_OUT, 3800, sys.argv[1:])


if __name__ == "__main__":
    main()
