"""Analogs of the public benchmark sets' volumes (Open SciVis, SDRBench); seeded.

Run: PYTHONPATH=. python results/kinds37/make.py DIR [NAME ...]
Writes DIR/<name>.npy and DIR/volumes.txt (name, int|float, set, shape, dtype).
Held out (named before any run, HELDOUT.md): bonsai_u8, beetle_u12, hydrogen_u8,
metal_i16, nyx_temp, isabel_qcloud, s3d_temp64.
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

HELD_OUT = ("bonsai_u8", "beetle_u12", "hydrogen_u8", "metal_i16", "nyx_temp",
            "isabel_qcloud", "s3d_temp64")  # fmt: skip


def grid(shape, lo=0.0, hi=1.0):
    return np.meshgrid(*(np.linspace(lo, hi, n) for n in shape), indexing="ij")


def gauss_field(rng, shape, slope, periodic=True):
    """A Gaussian random field of unit variance with power spectrum k^slope."""
    ks = [np.fft.fftfreq(n) for n in shape]
    kk = np.sqrt(sum(k**2 for k in np.meshgrid(*ks, indexing="ij")))
    kk.flat[0] = 1.0
    g = np.fft.ifftn(np.fft.fftn(rng.normal(size=shape)) * kk ** (slope / 2)).real
    return (g - g.mean()) / g.std()


def ct():
    a, _, _ = load("ct_head")
    return a.astype(np.float64)


# ---------------------------------------------------------------- integer volumes


def engine_u8(rng):
    """An industrial CT of a cast block: aluminium body, steel liners in four bores,
    coolant channels, beam-hardening cupping, streaks along x between the liners,
    reconstruction noise; air 0..~12, aluminium ~100, steel ~230 (uint8)."""
    shape = (128, 128, 160)
    z, y, x = grid(shape)
    body = (np.abs(y - 0.5) < 0.36) & (np.abs(x - 0.5) < 0.44) & (z > 0.08) & (z < 0.9)
    body &= ~((z > 0.7) & (np.abs(x - 0.5) > 0.3))  # a step on the top
    v = np.where(body, 100.0, 6.0)
    steel = np.zeros(shape, bool)
    for cx in (0.2, 0.4, 0.6, 0.8):
        r = np.sqrt((y - 0.5) ** 2 + (x - cx) ** 2)
        bore = (r < 0.075) & (z > 0.25)
        liner = (r >= 0.075) & (r < 0.09) & (z > 0.25) & body
        v[bore] = 6.0
        steel |= liner
    for cy in (0.25, 0.75):  # coolant channels along x
        ch = (np.sqrt((y - cy) ** 2 + (z - 0.45) ** 2) < 0.03) & body
        v[ch] = 6.0
    v[steel] = 230.0
    # cupping: denser material reads lower toward the middle of the body
    v -= np.where(body, 14.0 * (1 - ((x - 0.5) / 0.44) ** 2) * (1 - ((y - 0.5) / 0.36) ** 2), 0)
    # streaks between the liners: dark bands along x at the liners' y, fading along z
    v -= np.where(body & (z > 0.25), 18.0 * np.exp(-(((y - 0.5) / 0.03) ** 2)), 0)
    v = ndimage.gaussian_filter(v, 0.8)  # the scanner's blur
    v += ndimage.gaussian_filter(rng.normal(size=shape), 0.6) * 9.0
    return np.clip(np.rint(v), 0, 255).astype(np.uint8)


def bonsai_u8(rng):
    """A micro-CT of a small tree in a pot: soil with stones, a trunk that branches in
    random walks down to twigs of a voxel, leaves as thin discs; uint8."""
    shape = (160, 128, 128)
    v = np.zeros(shape)
    z, y, x = grid(shape)
    pot = (z > 0.72) & (np.sqrt((y - 0.5) ** 2 + (x - 0.5) ** 2) < 0.3 - 0.1 * (z - 0.72))
    soil = pot & (z > 0.76)
    v[pot] = 170.0
    v[soil] = 60.0 + 25.0 * gauss_field(rng, shape, -3.0)[soil]
    stones = soil & (gauss_field(rng, shape, -4.0) > 1.6)
    v[stones] = 200.0
    wood = np.zeros(shape)

    def branch(p, d, r, depth):
        for _ in range(int(40 * r)):
            p = p + d
            d = d + rng.normal(scale=0.12, size=3)
            d /= np.linalg.norm(d)
            i = np.rint(p).astype(int)
            if not all(0 <= i[k] < shape[k] for k in range(3)):
                return
            lo = np.maximum(i - int(r) - 1, 0)
            hi = np.minimum(i + int(r) + 2, shape)
            sl = tuple(slice(lo[k], hi[k]) for k in range(3))
            g = np.meshgrid(*(np.arange(lo[k], hi[k]) for k in range(3)), indexing="ij")
            dist = np.sqrt(sum((g[k] - p[k]) ** 2 for k in range(3)))
            wood[sl] = np.maximum(wood[sl], np.clip(r + 0.5 - dist, 0, 1))
            if depth < 5 and rng.random() < 0.06:
                branch(p.copy(), d + rng.normal(scale=0.8, size=3), max(r * 0.65, 0.6), depth + 1)
        if depth < 6:
            for _ in range(2):
                branch(p.copy(), d + rng.normal(scale=0.7, size=3), max(r * 0.6, 0.6), depth + 1)
            if r < 1.0:  # a leaf: a thin disc at the twig's end
                n = rng.normal(size=3)
                n /= np.linalg.norm(n)
                i = np.rint(p).astype(int)
                lo = np.maximum(i - 5, 0)
                hi = np.minimum(i + 6, shape)
                sl = tuple(slice(lo[k], hi[k]) for k in range(3))
                g = np.meshgrid(*(np.arange(lo[k], hi[k]) - p[k] for k in range(3)), indexing="ij")
                h = sum(g[k] * n[k] for k in range(3))
                rr = np.sqrt(sum(g[k] ** 2 for k in range(3)))
                wood[sl] = np.maximum(wood[sl], 0.5 * np.clip(1.2 - np.abs(h), 0, 1) * (rr < 4.5))

    branch(np.array([118.0, 64.0, 64.0]), np.array([-1.0, 0.0, 0.0]), 5.0, 0)
    v = np.maximum(v, 140.0 * wood)
    v = ndimage.gaussian_filter(v, 0.6) + rng.normal(size=shape) * 4.0 + 3.0
    return np.clip(np.rint(v), 0, 255).astype(np.uint8)


def foot_u8(rng):
    """The head CT windowed to [-300, 1700] HU into uint8, clipped at both ends (air and
    fat go to 0, dense bone to 255), as old CT volumes were distributed."""
    a = ct()
    return np.clip(np.rint((a + 300.0) * 255.0 / 2000.0), 0, 255).astype(np.uint8)


def beetle_u12(rng):
    """A stag-beetle-like micro-CT: 12 bits in uint16 (0..4095), a chitin shell (a thin
    bright skin over a dim body), mandibles and legs as thin tubes, air at a noise floor
    of ~60 with Poisson-like noise that grows with the signal."""
    shape = (96, 160, 128)
    z, y, x = grid(shape)
    body = ((z - 0.5) / 0.22) ** 2 + ((y - 0.55) / 0.3) ** 2 + ((x - 0.5) / 0.28) ** 2
    head = ((z - 0.5) / 0.16) ** 2 + ((y - 0.2) / 0.12) ** 2 + ((x - 0.5) / 0.2) ** 2
    d = np.minimum(np.sqrt(body), np.sqrt(head))
    v = np.where(d < 1, 700.0, 0.0) + 2600.0 * np.exp(-(((d - 1) / 0.025) ** 2))
    for s in (-1, 1):  # mandibles: curved tubes
        t = np.linspace(0, 1, 300)
        pts = np.stack([0.5 + 0 * t, 0.12 - 0.1 * t, 0.5 + s * (0.08 + 0.15 * np.sin(2 * t))], 1)
        for leg in range(3):  # legs
            tl = np.linspace(0, 1, 300)
            yy = 0.4 + 0.15 * leg + 0.05 * tl
            pts = np.concatenate(
                [pts, np.stack([0.5 + 0.3 * tl, yy, 0.5 + s * (0.2 + 0.25 * tl)], 1)]
            )
        idx = np.rint(pts * (np.array(shape) - 1)).astype(int)
        m = np.zeros(shape, bool)
        m[tuple(idx.T)] = True
        m = ndimage.binary_dilation(m, iterations=2)
        v[m] = np.maximum(v[m], 2200.0)
    v = ndimage.gaussian_filter(v, 0.7) + 60.0
    v += rng.normal(size=shape) * np.sqrt(v) * 1.2
    return np.clip(np.rint(v), 0, 4095).astype(np.uint16)


def chameleon_u16(rng):
    """The head CT over all 16 bits: HU -1024..3071 mapped to 0..65535 (x16) with a
    detector's noise (sigma ~12 counts) before rounding, so the low bits are noise."""
    a = ct()
    v = (a + 1024.0) * 16.0 + rng.normal(size=a.shape) * 12.0
    return np.clip(np.rint(v), 0, 65535).astype(np.uint16)


def rm_u8(rng):
    """A Richtmyer-Meshkov mixing layer quantised to uint8 (as the LLNL dataset is): a
    heavy fluid below a multimode perturbed interface whose amplitude has grown into
    bubbles and spikes, a diffuse mixing zone, a transmitted shock above; no noise."""
    shape = (128, 128, 128)
    z, y, x = grid(shape)
    h = np.zeros(shape[1:])
    yy, xx = np.meshgrid(np.linspace(0, 1, 128), np.linspace(0, 1, 128), indexing="ij")
    for _ in range(30):
        kx, ky = rng.integers(1, 9, size=2)
        h += (
            rng.normal()
            / (kx + ky)
            * np.cos(2 * np.pi * (kx * xx + rng.random()))
            * np.cos(2 * np.pi * (ky * yy + rng.random()))
        )
    h = 0.12 * h / np.abs(h).max()
    hb = 0.5 + np.where(h > 0, h, 1.8 * h)  # spikes of the heavy fluid grow longer
    width = 0.01 + 0.03 * np.abs(gauss_field(rng, shape, -3.0))
    frac = 0.5 * (1 + np.tanh((z - hb[None]) / width))
    rho = 1.0 + 2.0 * frac  # light above (1), heavy below (3)
    rho += 0.3 * (z > 0.85 + 0.01 * np.sin(6 * np.pi * xx)[None])  # the shock
    return np.clip(np.rint((rho - 1.0) / 2.3 * 255.0), 0, 255).astype(np.uint8)


def ml_u8(rng):
    """The Marschner-Lobb test signal (f_M = 6, alpha = 0.25) on 64^3 in [-1, 1]^3, as
    the benchmark's 41^3 is, scaled to uint8."""
    z, y, x = grid((64, 64, 64), -1.0, 1.0)
    r = np.sqrt(x**2 + y**2)
    rho = np.cos(2 * np.pi * 6 * np.cos(np.pi * r / 2))
    v = (1 - np.sin(np.pi * z / 2) + 0.25 * (1 + rho)) / (2 * 1.25)
    return np.rint(v * 255.0).astype(np.uint8)


def hydrogen_u8(rng):
    """A hydrogen atom's probability density (a 3d_{z^2} plus 2p_x superposition), 128^3,
    scaled by its maximum to uint8 as the benchmark volume is."""
    z, y, x = grid((128, 128, 128), -20.0, 20.0)
    r = np.sqrt(x**2 + y**2 + z**2) + 1e-9
    psi = r**2 * np.exp(-r / 3) * (3 * (z / r) ** 2 - 1) / 81.0
    psi += 0.4 * r * np.exp(-r / 2) * (x / r) / 8.0
    p = psi**2
    return np.rint(255.0 * p / p.max()).astype(np.uint8)


def aneurism_u8(rng):
    """A rotational angiography: a tree of contrast-filled vessels (radius 4 down to 1
    voxel) with an aneurysm sac, bright on a dark, slightly noisy background; uint8."""
    shape = (128, 128, 128)
    v = np.zeros(shape)

    def vessel(p, d, r, depth):
        n = int(rng.integers(25, 60))
        for _ in range(n):
            p = p + d
            d = d + rng.normal(scale=0.08, size=3)
            d /= np.linalg.norm(d)
            i = np.rint(p).astype(int)
            if not all(2 <= i[k] < shape[k] - 2 for k in range(3)):
                return
            lo = np.maximum(i - int(r) - 2, 0)
            hi = np.minimum(i + int(r) + 3, shape)
            sl = tuple(slice(lo[k], hi[k]) for k in range(3))
            g = np.meshgrid(*(np.arange(lo[k], hi[k]) for k in range(3)), indexing="ij")
            dist = np.sqrt(sum((g[k] - p[k]) ** 2 for k in range(3)))
            v[sl] = np.maximum(v[sl], np.clip(r + 0.5 - dist, 0, 1))
        if depth < 5 and r > 1.0:
            for _ in range(2):
                vessel(p.copy(), d + rng.normal(scale=0.6, size=3), max(r * 0.72, 1.0), depth + 1)

    vessel(np.array([125.0, 64.0, 64.0]), np.array([-1.0, 0.1, 0.0]), 4.0, 0)
    zz, yy, xx = np.meshgrid(*(np.arange(n) for n in shape), indexing="ij")
    sac = np.sqrt((zz - 70) ** 2 + (yy - 58) ** 2 + (xx - 70) ** 2) < 7
    v[sac] = 1.0
    v = ndimage.gaussian_filter(v, 0.7) * 235.0 + 8.0 + rng.normal(size=shape) * 3.0
    return np.clip(np.rint(v), 0, 255).astype(np.uint8)


def _rings(shape, rng, amp):
    """Ring artifacts of a micro-CT: an offset per radius about the rotation axis (the
    volume's centre in y, x), the same in every slice (a detector element's gain)."""
    _, ny, nx = shape
    yy, xx = np.meshgrid(np.arange(ny) - ny / 2, np.arange(nx) - nx / 2, indexing="ij")
    rad = np.sqrt(yy**2 + xx**2).astype(int)
    off = rng.normal(size=rad.max() + 1) * amp * (rng.random(rad.max() + 1) < 0.3)
    return off[rad][None]


def ring_u16(rng):
    """The head CT offset to unsigned (HU + 1024) with ring artifacts: 30 % of the
    detector's radii off by N(0, 25) counts in every slice; uint16."""
    a = ct() + 1024.0
    v = a + _rings(a.shape, rng, 25.0) * (a > 50)
    return np.clip(np.rint(v), 0, 65535).astype(np.uint16)


def metal_i16(rng):
    """The head CT with a metal implant (a screw at 3071 HU, the scanner's clip) and the
    streaks it throws: dark and bright radial bands from the implant in each slice it
    crosses, fading with distance; int16 HU."""
    a = ct()
    nz, ny, nx = a.shape
    zz, yy, xx = np.meshgrid(*(np.arange(n, dtype=float) for n in a.shape), indexing="ij")
    cy, cx = 150.0, 110.0
    screw = (np.sqrt((yy - cy) ** 2 + (xx - cx) ** 2) < 3.5) & (zz > 30) & (zz < 70)
    ang = np.arctan2(yy - cy, xx - cx)
    rr = np.sqrt((yy - cy) ** 2 + (xx - cx) ** 2) + 1
    phases = rng.random(8) * 2 * np.pi
    streak = sum(np.cos(k * ang + phases[k - 1]) for k in range(1, 9))
    streak = 350.0 * np.sign(streak) * np.abs(streak) ** 1.5 / 8.0 / np.sqrt(rr / 4)
    band = (zz > 30) & (zz < 70) & (a > -900)
    v = a + np.where(band, streak, 0)
    v[screw] = 3071.0
    return np.clip(np.rint(v), -1024, 3071).astype(np.int16)


def lowdose_i16(rng):
    """The head CT at a low dose: noise of sigma ~45 HU with the texture a filtered back
    projection gives (high-passed, correlated over ~2 voxels in-plane), inside the body;
    int16 HU."""
    a = ct()
    n = rng.normal(size=a.shape)
    n = ndimage.gaussian_filter(n, (0.4, 1.2, 1.2)) - 0.6 * ndimage.gaussian_filter(n, (0.5, 3, 3))
    n *= 45.0 / n.std()
    v = a + np.where(a > -900, n, n * 0.2)
    return np.clip(np.rint(v), -1024, 3071).astype(np.int16)


# ---------------------------------------------------------------- float fields


def miranda_visc(rng):
    """Miranda's viscosity: the floor value 1e-4 almost everywhere and smooth positive
    bumps (a nonlinear function of the mixing) inside a Rayleigh-Taylor layer; 96^3."""
    shape = (96, 96, 96)
    z, _, _ = grid(shape)
    g = gauss_field(rng, shape, -4.0)
    mix = np.exp(-(((z - 0.5 - 0.06 * g) / 0.12) ** 2))
    return (1e-4 + 2.5e-3 * np.maximum(mix * (1 + 0.5 * g), 0) ** 2).astype(np.float32)


def nyx_vel(rng):
    """A Nyx velocity component: the gradient of a periodic potential (large-scale flow,
    k^-4 density) plus infall onto 60 halos (a 1/sqrt(r) profile pointing inwards),
    km/s; 128^3, periodic."""
    n = 128
    k = np.fft.fftfreq(n)
    kz, _, _ = np.meshgrid(k, k, k, indexing="ij")
    kk = np.sqrt(sum(q**2 for q in np.meshgrid(k, k, k, indexing="ij")))
    kk[0, 0, 0] = 1.0
    dk = np.fft.fftn(rng.normal(size=(n, n, n))) * kk ** (-2.0)
    v = np.fft.ifftn(1j * kz / kk**2 * dk).real
    v = 300.0 * v / v.std()
    z, y, x = np.meshgrid(*(np.arange(n, dtype=float),) * 3, indexing="ij")
    for _ in range(60):
        c = rng.random(3) * n
        m = rng.lognormal(0, 0.8)
        dz = (z - c[0] + n / 2) % n - n / 2
        dy = (y - c[1] + n / 2) % n - n / 2
        dx = (x - c[2] + n / 2) % n - n / 2
        r = np.sqrt(dz**2 + dy**2 + dx**2) + 0.7
        v += -400.0 * m * dz / r / np.sqrt(r) * np.exp(-r / 20)
    return v.astype(np.float32)


def nyx_temp(rng):
    """A Nyx gas temperature in K, not logged: the IGM's T = 1e4 (rho)^0.6 on a
    log-normal density, plus shock-heated halos at 1e6..1e7 K; 96^3 float32."""
    shape = (96, 96, 96)
    g = gauss_field(rng, shape, -3.0)
    rho = np.exp(1.2 * g)
    t = 1e4 * rho**0.6
    z, y, x = np.meshgrid(*(np.arange(n, dtype=float) for n in shape), indexing="ij")
    for _ in range(25):
        c = rng.random(3) * 96
        r = np.sqrt((z - c[0]) ** 2 + (y - c[1]) ** 2 + (x - c[2]) ** 2)
        t += 10 ** rng.uniform(6, 7) * np.exp(-((r / rng.uniform(2, 6)) ** 2))
    return t.astype(np.float32)


def isabel_pfill(rng):
    """Hurricane Isabel's way of marking land: the real air temperature of climate_t
    (17 levels x 96x192), with 1e35 at the levels below the ground where land is: land
    from sst_monthly's land cells, the ground's height from a smooth random topography
    (0..4 levels)."""
    t, _, _ = load("climate_t")
    t = t.astype(np.float32).copy()
    sst, _, _ = load("sst_monthly")
    land = sst[0] <= -1.79
    land = (
        ndimage.zoom(land.astype(float), (96 / land.shape[0], 192 / land.shape[1]), order=0) > 0.5
    )
    topo = 4.0 * (0.5 + 0.5 * gauss_field(rng, (96, 192), -4.0) / 2.0)
    nl = np.where(land, np.clip(np.rint(topo), 1, 4), 0).astype(int)
    lev = np.arange(t.shape[0])[:, None, None]
    # the file's levels run from 1000 hPa (index 0) up
    t[lev < nl[None]] = 1e35
    return t


def isabel_qcloud(rng):
    """Hurricane Isabel's QCLOUD: cloud water mixing ratio (kg/kg), exact zeros outside
    clouds, within them a smooth positive field to ~2e-3 with a spiral band structure,
    only between levels 10 and 70 of 96; 96x128x128 float32."""
    shape = (96, 128, 128)
    z, y, x = grid(shape)
    r = np.sqrt((y - 0.5) ** 2 + (x - 0.5) ** 2)
    th = np.arctan2(y - 0.5, x - 0.5)
    spiral = np.cos(3 * (th - 8 * r)) * np.exp(-r / 0.35)
    g = gauss_field(rng, shape, -3.5)
    c = 0.9 * spiral + 0.6 * g + 0.8 * np.exp(-((r / 0.08) ** 2)) - 0.45
    c *= np.exp(-(((z - 0.45) / 0.22) ** 4))
    q = np.where(c > 0, 2e-3 * np.maximum(c, 0) ** 1.5, 0.0)
    q[(z < 0.1) | (z > 0.73)] = 0.0
    return q.astype(np.float32)


def _flame(rng, shape):
    """A wrinkled premixed flame: the progress variable c in [0, 1] across a front at
    z ~ 0.5 displaced by turbulence, thin (~3 voxels)."""
    z, _, _ = grid(shape)
    g = gauss_field(rng, shape, -3.7)
    s = z - 0.5 - 0.12 * g
    return 0.5 * (1 + np.tanh(s / 0.015)), s


def s3d_oh64(rng):
    """An S3D radical mass fraction (OH-like), float64: peaked at ~3e-3 in the flame
    sheet (c ~ 0.8), a burnt equilibrium of 5e-4 behind it, decaying tails to ~1e-30
    ahead of it (never an exact zero); 96^3."""
    c, s = _flame(rng, (96, 96, 96))
    y = 3e-3 * np.exp(-(((c - 0.8) / 0.12) ** 2)) + 5e-4 * c**4
    y *= np.exp(np.minimum(s, 0) / 0.01)
    return np.maximum(y, 1e-30)


def s3d_temp64(rng):
    """An S3D temperature in K, float64: 300 K unburnt, ~2100 K burnt with the
    turbulence's +-40 K inside, across a thin wrinkled front; 96^3."""
    c, _ = _flame(rng, (96, 96, 96))
    return 300.0 + 1800.0 * c + 40.0 * c * gauss_field(rng, (96, 96, 96), -3.0)


def qmc_orb4d(rng):
    """QMCPack-like orbitals: 8 single-particle orbitals on a periodic 48^3 cell of 8
    atoms, each a Bloch-phase sum of plane waves (k^-3 amplitudes up to |G| = 6) plus
    cusps at the atoms; (8, 48, 48, 48) float32."""
    n = 48
    z, y, x = np.meshgrid(*(np.arange(n) / n,) * 3, indexing="ij")
    atoms = rng.random((8, 3))
    out = np.empty((8, n, n, n), np.float32)
    for o in range(8):
        f = np.zeros((n, n, n))
        for _ in range(60):
            g = rng.integers(-6, 7, size=3)
            kk = np.sqrt((g**2).sum()) + 1
            f += (
                rng.normal()
                / kk**1.5
                * np.cos(2 * np.pi * (g[0] * z + g[1] * y + g[2] * x) + rng.random() * 6.28)
            )
        for a in atoms:
            d = [(q - a[i] + 0.5) % 1 - 0.5 for i, q in enumerate((z, y, x))]
            r = np.sqrt(sum(q**2 for q in d)) * n
            f += rng.normal() * 2.0 * np.exp(-r / 1.5)
        out[o] = f
    return out


MAKERS = {
    f.__name__: f
    for f in (
        engine_u8,
        bonsai_u8,
        foot_u8,
        beetle_u12,
        chameleon_u16,
        rm_u8,
        ml_u8,
        hydrogen_u8,
        aneurism_u8,
        ring_u16,
        metal_i16,
        lowdose_i16,
        miranda_visc,
        nyx_vel,
        nyx_temp,
        isabel_pfill,
        isabel_qcloud,
        s3d_oh64,
        s3d_temp64,
        qmc_orb4d,
    )  # fmt: skip
}


def main() -> None:
    write_volumes(MAKERS, HELD_OUT, 3700, sys.argv[1:])


if __name__ == "__main__":
    main()
