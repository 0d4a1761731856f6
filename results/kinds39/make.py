"""Analogs of imaging and simulation volumes of kinds no earlier trial had; seeded.

Run: PYTHONPATH=. python results/kinds39/make.py DIR [NAME ...]
Writes DIR/<name>.npy and DIR/volumes.txt (name, int|float, set, shape, dtype).
Held out (named before any run, HELDOUT.md): us_u8, radar_u8, rock_u8, pet_f32, amr_f32.
Each maker's docstring says what it stands in for and how it is made.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
from scipy import ndimage
from scipy.spatial import cKDTree

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "scripts"))

from datasets import load  # noqa: E402
from trialkit import write_volumes  # noqa: E402

HELD_OUT = ("us_u8", "radar_u8", "rock_u8", "pet_f32", "amr_f32")


def grid(shape, lo=0.0, hi=1.0):
    return np.meshgrid(*(np.linspace(lo, hi, n) for n in shape), indexing="ij")


def gauss_field(rng, shape, slope):
    """A Gaussian random field of unit variance with power spectrum k^slope (periodic)."""
    ks = [np.fft.fftfreq(n) for n in shape]
    kk = np.sqrt(sum(k**2 for k in np.meshgrid(*ks, indexing="ij")))
    kk.flat[0] = 1.0
    g = np.fft.ifftn(np.fft.fftn(rng.normal(size=shape)) * kk ** (slope / 2)).real
    return (g - g.mean()) / g.std()


def voronoi(rng, shape, n):
    """Nearest and second-nearest seed distances (voxels) and the nearest seed's index."""
    seeds = rng.random((n, 3)) * np.array(shape)
    pts = np.stack(np.meshgrid(*(np.arange(s) + 0.5 for s in shape), indexing="ij"), -1)
    d, i = cKDTree(seeds).query(pts.reshape(-1, 3), k=2)
    return d[:, 0].reshape(shape), d[:, 1].reshape(shape), i[:, 0].reshape(shape)


def q(v, dtype):
    info = np.iinfo(dtype)
    return np.clip(np.rint(v), info.min, info.max).astype(dtype)


# ---------------------------------------------------------------- integer volumes


def fibsem_u8(rng):
    """FIB-SEM electron microscopy of brain tissue (uint8, 96 x 160 x 160; z is the milling
    direction): Voronoi cells whose walls are dark membranes 2-3 voxels thick, a
    cytoplasm texture (a k^-2 field), dark vesicles; curtaining: vertical stripes (a
    function of x, constant along y) that drift slowly from slice to slice; each slice's
    brightness drifts (a random walk, +-6 grey levels); SEM noise sigma 7."""
    shape = (96, 160, 160)
    d1, d2, _ = voronoi(rng, shape, 900)
    mem = np.exp(-(((d2 - d1) / 1.3) ** 2))
    tex = gauss_field(rng, shape, -2.0)
    v = 150 + 12 * tex - 85 * mem
    ves = gauss_field(rng, shape, -5.0)
    v -= 40 * (ves > 2.2)
    stripes = np.cumsum(rng.normal(size=(shape[0], shape[2])), axis=0) * 0.4
    stripes = ndimage.gaussian_filter1d(stripes, 0.8, axis=1) + rng.normal(size=shape[2]) * 6
    v += stripes[:, None, :]
    v += np.cumsum(rng.normal(scale=1.0, size=shape[0]))[:, None, None]
    v = ndimage.gaussian_filter(v, 0.6) + rng.normal(scale=7.0, size=shape)
    return q(v, np.uint8)


def _rock(rng, shape, n_grains, rmin, rmax, pore, grain, mineral, sigma, dtype):
    """Porous rock micro-CT: overlapping spherical grains in a cylinder; pores between
    them; a few dense mineral specks; beam hardening (cupping: brighter by 12 % at the
    cylinder's edge); air outside; blurred; Gaussian noise."""
    z, y, x = grid(shape)
    r = np.hypot(y - 0.5, x - 0.5)
    cyl = r < 0.47
    c = rng.random((n_grains, 3)) * np.array(shape)
    rad = rng.uniform(rmin, rmax, n_grains)
    pts = np.stack(np.meshgrid(*(np.arange(s) for s in shape), indexing="ij"), -1).reshape(-1, 3)
    tree = cKDTree(c)
    d, i = tree.query(pts, k=4)
    solid = np.any(d < rad[i], axis=1).reshape(shape)
    spec = ndimage.binary_dilation(rng.random(shape) < 2e-5, iterations=1) & solid
    v = np.where(solid, grain, pore).astype(float)
    v[spec] = mineral
    v *= 1 + 0.12 * (r / 0.47) ** 2
    v = np.where(cyl, v, pore * 0.4)
    v = ndimage.gaussian_filter(v, 0.8) + rng.normal(size=shape) * sigma
    return q(v, dtype)


def rock_u16(rng):
    """Carbonate micro-CT (uint16, full 16-bit range, 128^3): grains of radius 3-9 voxels,
    pore ~9000, grain ~24000, mineral specks ~52000, noise sigma 1100 (see _rock)."""
    return _rock(rng, (128, 128, 128), 2600, 3, 9, 9000, 24000, 52000, 1100, np.uint16)


def rock_u8(rng):
    """Sandstone micro-CT as uint8 (144^3): smaller grains of radius 2-6, pore ~55,
    grain ~150, specks ~240, noise sigma 9 (see _rock)."""
    return _rock(rng, (144, 144, 144), 9000, 2, 6, 55, 150, 240, 9, np.uint8)


def lightsheet_u16(rng):
    """Light-sheet fluorescence microscopy (uint16 sCMOS, 64 x 192 x 192): a camera offset
    of 100 ADU, 2.17 ADU a photo-electron, read noise sigma 1.6 ADU; autofluorescence of
    ~4 photons, sparse bright nuclei (ellipsoids, 60-400 photons, elongated along z by the
    light sheet's thickness); stripe shadows along x (the illumination direction) from
    absorbers, each a multiplicative dip of 20-60 %."""
    shape = (64, 192, 192)
    z, y, x = np.meshgrid(*(np.arange(s, dtype=float) for s in shape), indexing="ij")
    sig = np.zeros(shape)
    n = 260
    c = rng.random((n, 3)) * np.array(shape)
    b = rng.uniform(60, 400, n)
    for (cz, cy, cx), bb in zip(c, b):
        sl = tuple(
            slice(max(0, int(p) - 9), min(s, int(p) + 10)) for p, s in zip((cz, cy, cx), shape)
        )
        rr = ((z[sl] - cz) / 3.0) ** 2 + ((y[sl] - cy) / 4.0) ** 2 + ((x[sl] - cx) / 4.0) ** 2
        sig[sl] += bb * np.exp(-(rr**2) / 2)
    sig += 4 + 2 * (gauss_field(rng, shape, -4.0) + 1.5).clip(0)
    shade = np.ones(shape[:2])
    for _ in range(14):
        zc, yc, w, depth = (
            rng.uniform(0, shape[0]),
            rng.uniform(0, shape[1]),
            rng.uniform(1, 3),
            rng.uniform(0.2, 0.6),
        )
        shade *= 1 - depth * np.exp(-(((np.arange(shape[1]) - yc) / w) ** 2))[None, :] * np.exp(
            -(((np.arange(shape[0]) - zc) / 12) ** 2))[:, None]  # fmt: skip
    sig *= shade[:, :, None]
    e = rng.poisson(sig)
    return q(100 + 2.17 * e + rng.normal(scale=1.6, size=shape), np.uint16)


def cbct_i16(rng):
    """Cone-beam CT (int16 HU, 108 x 192 x 192) from the corpus's head CT: resampled to
    192^2 in-plane, smoothed, with CBCT's noise (sigma 35 HU), a low-frequency shading
    (cupping, -60 HU at the centre), streaks from the bone (lines through the densest
    voxels of each slice), and a cylindrical field of view: -1000 outside it."""
    a = load("ct_head")[0].astype(float)
    a = ndimage.zoom(a, (1, 0.75, 0.75), order=1)
    shape = a.shape
    z, y, x = grid(shape)
    r = np.hypot(y - 0.5, x - 0.5)
    v = ndimage.gaussian_filter(a, 0.7) - 60 * np.exp(-((r / 0.3) ** 2)) * (a > -500)
    yy, xx = np.mgrid[: shape[1], : shape[2]].astype(float)
    for k in range(shape[0]):
        hot = np.argwhere(a[k] > 1500)
        if len(hot) < 2:
            continue
        for _ in range(3):
            p, q2 = hot[rng.integers(len(hot), size=2)]
            dy, dx = q2 - p
            nrm = np.hypot(dy, dx) or 1.0
            dist = np.abs((yy - p[0]) * dx - (xx - p[1]) * dy) / nrm
            v[k] += rng.choice([-1, 1]) * 90 * np.exp(-((dist / 0.8) ** 2))
    v += rng.normal(scale=35, size=shape)
    v = np.where(r < 0.49, v, -1000)
    return q(v, np.int16)


def cells_u16(rng):
    """Instance segmentation of many small cells (uint16 labels, 112 x 144 x 144): Voronoi
    cells of ~3800 seeds inside a tissue (a blobby mask), one voxel of background (0)
    between neighbours, ids a random permutation of 1..N, as a segmenter leaves them."""
    shape = (112, 144, 144)
    d1, d2, i = voronoi(rng, shape, 3800)
    tissue = gauss_field(rng, shape, -6.0) > -0.6
    lab = (i + 1) * ((d2 - d1) > 0.9) * tissue
    perm = np.concatenate([[0], rng.permutation(3800) + 1])
    lab = perm[lab]
    # small fragments under 20 voxels are dropped, as a size filter does
    counts = np.bincount(lab.ravel(), minlength=3801)
    lab[counts[lab] < 20] = 0
    return lab.astype(np.uint16)


def us_u8(rng):
    """3-D ultrasound (uint8, 128^3): a pyramidal fan from a probe at the top (+-35 degrees
    both ways), zero outside it; inside, speckle (the magnitude of a complex Gaussian field
    blurred by an anisotropic PSF: short axially, long laterally) times an echogenicity
    map (tissue, a dark cyst, a bright wall), depth attenuation with time-gain
    compensation, log-compressed to 0..255."""
    shape = (128, 128, 128)
    z, y, x = grid(shape)
    depth = z + 0.05
    th_y, th_x = np.arctan2(y - 0.5, depth), np.arctan2(x - 0.5, depth)
    rr = np.sqrt(depth**2 + (y - 0.5) ** 2 + (x - 0.5) ** 2)
    fan = (np.abs(th_y) < 0.61) & (np.abs(th_x) < 0.61) & (rr < 1.0) & (rr > 0.08)
    c = rng.normal(size=shape) + 1j * rng.normal(size=shape)
    c = ndimage.gaussian_filter(c.real, (0.7, 1.8, 1.8)) + 1j * ndimage.gaussian_filter(
        c.imag, (0.7, 1.8, 1.8)
    )
    echo = 1 + 0.4 * gauss_field(rng, shape, -5.0)
    cyst = ((z - 0.55) / 0.12) ** 2 + ((y - 0.45) / 0.1) ** 2 + ((x - 0.55) / 0.1) ** 2
    echo = np.where(cyst < 1, 0.08, echo) + 2.5 * np.exp(-(((np.sqrt(cyst) - 1.0) / 0.08) ** 2))
    amp = np.abs(c) * echo.clip(0.02) * np.exp(-1.2 * rr) * (1 + 0.9 * rr)
    db = 20 * np.log10(amp / np.percentile(amp[fan], 99.5) + 1e-6)
    v = 255 * (db + 50) / 50
    return np.where(fan, q(v, np.uint8), 0).astype(np.uint8)


def radar_u8(rng):
    """Weather radar reflectivity on a 3-D grid (uint8 codes, 20 x 200 x 200): a NEXRAD-style
    code 2 (dBZ + 32) + 0.5 (0.5 dB steps), 0 below -32 dBZ ... no echo, 255 no data. Storm
    cells (exponentials of a k^-4 field) fading with height; gridded from polar gates (9
    elevations, 1-degree beams, 250 m gates) by nearest neighbour forward mapping, so cells
    no gate falls in (far range, between elevations) are no data, as is the cone of
    silence above the radar and beyond its range."""
    nz, ny, nx = 20, 200, 200
    field = gauss_field(rng, (nz, ny, nx), -4.0)
    base = 10 + 14 * field - 1.6 * np.arange(nz)[:, None, None]
    dbz = np.where(base > 8, base + 18 * (field > 1.5), -40.0)
    dbz = dbz + rng.normal(scale=1.0, size=dbz.shape)
    out = np.full((nz, ny, nx), 255, np.uint8)
    elev = np.radians([0.5, 1.5, 2.4, 3.4, 4.3, 6.0, 9.9, 14.6, 19.5])
    az = np.radians(np.arange(0, 360, 1.0))
    rng_km = np.arange(2.0, 140.0, 0.25)
    for e in elev:
        zz = rng_km * np.sin(e) + rng_km**2 / (2 * 8500.0)
        hor = rng_km * np.cos(e)
        iz = np.rint(zz / 0.5).astype(int)
        for a in az:
            iy = np.rint(ny / 2 + hor * np.cos(a) / 0.7).astype(int)
            ix = np.rint(nx / 2 + hor * np.sin(a) / 0.7).astype(int)
            ok = (iz >= 0) & (iz < nz) & (iy >= 0) & (iy < ny) & (ix >= 0) & (ix < nx)
            val = dbz[iz[ok], iy[ok], ix[ok]]
            code = np.where(val < -32, 0, np.clip(np.rint(2 * (val + 32) + 0.5), 1, 254))
            out[iz[ok], iy[ok], ix[ok]] = code
    return out


# ---------------------------------------------------------------- float fields


def cryoet_f32(rng):
    """A cryo-electron tomogram (float32, 96 x 128 x 128): membranes (two shells) and
    ribosome-like particles (clusters of blobs), low contrast, buried in noise at an SNR
    of ~0.1; a missing wedge (tilts +-60 degrees about y: Fourier coefficients with
    |kz| > |kx| tan 60 are removed from signal and noise), which smears each feature
    into streaks along z; the CTF's low-frequency loss as a high-pass."""
    shape = (96, 128, 128)
    z, y, x = np.meshgrid(*(np.arange(s, dtype=float) for s in shape), indexing="ij")
    s = np.zeros(shape)
    for cz, cy, cx, rad in ((48, 60, 50, 38), (40, 70, 95, 20)):
        rr = np.sqrt((z - cz) ** 2 + (y - cy) ** 2 + (x - cx) ** 2)
        s += np.exp(-(((rr - rad) / 1.5) ** 2))
    for _ in range(120):
        c = rng.random(3) * np.array(shape)
        for _ in range(5):
            p = c + rng.normal(scale=2.5, size=3)
            sl = tuple(slice(max(0, int(t) - 6), min(n, int(t) + 7)) for t, n in zip(p, shape))
            s[sl] += 0.8 * np.exp(
                -((z[sl] - p[0]) ** 2 + (y[sl] - p[1]) ** 2 + (x[sl] - p[2]) ** 2) / 5.0
            )
    s = s / s.std()
    kz, ky, kx = np.meshgrid(*(np.fft.fftfreq(n) for n in shape), indexing="ij")
    keep = np.abs(kz) <= np.abs(kx) * np.tan(np.radians(60))
    k = np.sqrt(kz**2 + ky**2 + kx**2)
    filt = keep * (1 - np.exp(-((k / 0.03) ** 2))) * np.exp(-((k / 0.35) ** 2))
    v = s + rng.normal(scale=3.0, size=shape)
    v = np.fft.ifftn(np.fft.fftn(v) * filt).real
    return (v / v.std()).astype(np.float32)


def phase_f32(rng):
    """MRI phase (rad, float32, 96 x 128 x 128), wrapped to [-pi, pi): inside a head (an
    ellipsoid) a smooth B0 field (low-order polynomial plus a dipole near an air sinus)
    times the echo time wraps 3-6 times across the head, plus phase noise ~0.05 rad; outside
    it, uniform random phase (the noise of a background with no signal)."""
    shape = (96, 128, 128)
    z, y, x = grid(shape, -1.0, 1.0)
    head = (z / 0.85) ** 2 + (y / 0.9) ** 2 + (x / 0.75) ** 2 < 1
    dz, dy, dx = z + 0.2, y - 0.45, x
    r2 = dz**2 + dy**2 + dx**2 + 0.01
    dip = (3 * dz**2 / r2 - 1) / r2**1.5 * 0.012
    b0 = 4 * z + 3 * y * x - 5 * x**2 + 2.5 * z * y + dip * 40 + 0.6 * gauss_field(rng, shape, -5.0)
    ph = 2.5 * b0 + rng.normal(scale=0.05, size=shape)
    ph = np.where(head, ph, rng.uniform(-np.pi, np.pi, size=shape))
    w = (ph + np.pi) % (2 * np.pi) - np.pi
    return w.astype(np.float32)


def dti_f32(rng):
    """A diffusion tensor field (mm^2/s, float32, 48 x 80 x 80 x 6: Dxx, Dxy, Dxz, Dyy, Dyz,
    Dzz as the last axis, as FSL / dipy store it): CSF isotropic 3e-3, grey matter 0.8e-3,
    white matter eigenvalues (1.7, 0.3, 0.3)e-3 along a smooth fibre direction field, 4 %
    noise on each component, zero outside the brain."""
    shape = (48, 80, 80)
    z, y, x = grid(shape, -1.0, 1.0)
    brain = (z / 0.85) ** 2 + (y / 0.95) ** 2 + (x / 0.8) ** 2 < 1
    t = gauss_field(rng, shape, -5.0)
    csf = (t > 1.4) | ((y / 0.15) ** 2 + (x / 0.3) ** 2 + (z / 0.4) ** 2 < 1)
    wm = (t < 0.2) & ~csf
    d = np.stack([gauss_field(rng, shape, -6.0) + a for a in (1.0, 0.3, 0.5)], -1)
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    lam1 = np.where(wm, 1.7e-3, np.where(csf, 3e-3, 0.8e-3))
    lam2 = np.where(wm, 0.3e-3, lam1)
    D = (
        lam2[..., None, None] * np.eye(3)
        + (lam1 - lam2)[..., None, None] * d[..., :, None] * d[..., None, :]
    )
    comp = np.stack(
        [D[..., 0, 0], D[..., 0, 1], D[..., 0, 2], D[..., 1, 1], D[..., 1, 2], D[..., 2, 2]], -1
    )
    comp += rng.normal(scale=0.04 * 1e-3, size=comp.shape)
    return (comp * brain[..., None]).astype(np.float32)


def dose_f32(rng):
    """A radiotherapy dose distribution (Gy, float32, 96 x 128 x 128): seven coplanar
    photon beams converging on a target (each: build-up then exponential fall with depth
    in the body, an error-function penumbra of ~3 mm at its field edges, a little
    scatter), summed to ~70 Gy in the target; zero outside the body (an elliptic
    cylinder); 0.5 % Monte Carlo noise where the dose is above 1 Gy."""
    from scipy.special import erf

    shape = (96, 128, 128)
    z, y, x = grid(shape, -1.0, 1.0)
    body = (y / 0.8) ** 2 + (x / 0.95) ** 2 < 1
    tz, ty, tx = 0.05, 0.1, -0.15
    dose = np.zeros(shape)
    for ang in np.radians(np.arange(0, 360, 360 / 7) + 10):
        u = np.array([np.cos(ang), np.sin(ang)])
        along = (y - ty) * u[0] + (x - tx) * u[1]
        perp = -(y - ty) * u[1] + (x - tx) * u[0]
        depth = (along + 1.2).clip(0)
        dd = (1 - np.exp(-depth / 0.04)) * np.exp(-0.35 * depth)
        hw, hz = 0.22, 0.25
        lat = (
            (erf((hw - np.abs(perp)) / 0.04) + 1) / 2 * (erf((hz - np.abs(z - tz)) / 0.04) + 1) / 2
        )
        dose += dd * (lat + 0.03 * np.exp(-np.abs(perp) / 0.2))
    dose *= 70 / dose[48, 70, 50:60].mean()
    dose = np.where(body, dose, 0)
    dose *= 1 + 0.005 * rng.normal(size=shape) * (dose > 1)
    return dose.astype(np.float32)


def pet_f32(rng):
    """PET SUV (float32, 96 x 128 x 128): a body (elliptic cylinder, SUV ~0.8) with liver
    (2.2), brain (7), heart wall (4), bladder (25) and eight hot lesions (4-14), reconstructed
    from low counts: Poisson counts at ~6 a voxel for SUV 1, scaled back, then a 2-voxel
    Gaussian post-filter; nearly zero (a small positive tail) outside the body."""
    shape = (96, 128, 128)
    z, y, x = grid(shape, -1.0, 1.0)

    def ell(c, r):
        return ((z - c[0]) / r[0]) ** 2 + ((y - c[1]) / r[1]) ** 2 + ((x - c[2]) / r[2]) ** 2 < 1

    suv = np.where((y / 0.6) ** 2 + (x / 0.8) ** 2 < 1, 0.8, 0.02)
    suv[ell((0.85, 0, 0), (0.2, 0.4, 0.35))] = 7
    suv[ell((0.2, 0.1, -0.35), (0.25, 0.3, 0.3))] = 2.2
    suv[ell((0.4, -0.1, 0.2), (0.12, 0.15, 0.15))] = 4
    suv[ell((-0.85, 0, 0), (0.1, 0.15, 0.15))] = 25
    for _ in range(8):
        c = rng.uniform(-0.6, 0.6, 3) * (1, 0.5, 0.6)
        suv[ell(c, np.array((0.04, 0.05, 0.05)) * rng.uniform(0.6, 1.6))] = rng.uniform(4, 14)
    counts = rng.poisson(suv * 6.0) / 6.0
    return ndimage.gaussian_filter(counts, 2.0).astype(np.float32)


def amr_f32(rng):
    """An adaptive-mesh-refinement field resampled to a uniform grid (float32, 128^3): a
    blast wave's density (a spherical shock of ratio 4 over a perturbed medium) sampled at
    the cell centres of blocks of 16^3 voxels refined to levels 0..3 (cells of 8, 4, 2, 1
    voxels) where the density's gradient is high, each cell's value repeated over its
    voxels (piecewise constant, as a resampler injecting coarse cells does)."""
    n = 128
    z, y, x = grid((n, n, n), -1.0, 1.0)
    r = np.sqrt(z**2 + y**2 + x**2)
    g = gauss_field(rng, (n, n, n), -4.0)
    rs = 0.55 + 0.03 * g
    rho = (
        1
        + 0.1 * g
        + 3 * np.exp(-(((r - rs) / 0.03) ** 2)) * (r < rs + 0.02)
        + 0.3 * (r < rs) * (r / rs) ** 3
    )
    grad = np.sqrt(sum(gg**2 for gg in np.gradient(rho)))
    out = np.empty_like(rho)
    b = 16
    for i in range(0, n, b):
        for j in range(0, n, b):
            for k in range(0, n, b):
                gm = grad[i : i + b, j : j + b, k : k + b].max()
                lev = 3 if gm > 0.2 else 2 if gm > 0.06 else 1 if gm > 0.02 else 0
                c = 8 >> lev
                blk = rho[i : i + b, j : j + b, k : k + b]
                m = blk[c // 2 :: c, c // 2 :: c, c // 2 :: c] if c > 1 else blk
                out[i : i + b, j : j + b, k : k + b] = np.repeat(
                    np.repeat(np.repeat(m, c, 0), c, 1), c, 2
                )
    return out.astype(np.float32)


MAKERS = {
    "fibsem_u8": fibsem_u8,
    "rock_u16": rock_u16,
    "lightsheet_u16": lightsheet_u16,
    "cbct_i16": cbct_i16,
    "cells_u16": cells_u16,
    "us_u8": us_u8,
    "radar_u8": radar_u8,
    "rock_u8": rock_u8,
    "cryoet_f32": cryoet_f32,
    "phase_f32": phase_f32,
    "dti_f32": dti_f32,
    "dose_f32": dose_f32,
    "pet_f32": pet_f32,
    "amr_f32": amr_f32,
}


def main() -> None:
    write_volumes(MAKERS, HELD_OUT, 3900, sys.argv[1:])


if __name__ == "__main__":
    main()
