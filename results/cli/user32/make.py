"""Volumes of kinds volpack was not tried on, as a new user would bring them (seeded).

    PYTHONPATH=. python results/cli/user32/make.py DIR

Real scans of scripts/datasets.py where a kind can be made of one (stored as the user's
program would store it), synthetic otherwise. Each is written as DIR/NAME.npy; the list
with a line of description goes to DIR/volumes.txt.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
from scipy import ndimage

sys.path.insert(0, str(Path(__file__).resolve().parents[3] / "scripts"))
from datasets import load  # noqa: E402


def voronoi_labels(shape, n_seeds, rng, dtype, id_max):
    """A watershed-like segmentation: each voxel takes the id of its nearest seed (on a
    slightly warped grid so borders are not planes), ids drawn at random below id_max."""
    seeds = np.zeros(shape, bool)
    idx = tuple(rng.integers(0, s, n_seeds) for s in shape)
    seeds[idx] = True
    lab, n = ndimage.label(seeds)
    # warp: distance transform on a noisy grid is not available; jitter the seed map
    # by smoothing noise into the distance and taking the nearest seed's label
    _, inds = ndimage.distance_transform_edt(~seeds, return_indices=True)
    out = lab[tuple(inds)]
    noise = ndimage.gaussian_filter(rng.standard_normal(shape), 2.0)
    shift = np.clip(np.round(noise * 6), -2, 2).astype(int)
    zz = np.clip(np.arange(shape[0])[:, None, None] + shift, 0, shape[0] - 1)
    out = out[zz, np.arange(shape[1])[None, :, None], np.arange(shape[2])[None, None, :]]
    ids = np.unique(rng.integers(1, id_max, size=2 * n + 8, dtype=np.uint64))
    ids = rng.permutation(ids)[: n + 1].astype(dtype)  # distinct, in random order
    ids[0] = 0
    return ids[out]


def blobs(shape, n, radius, rng):
    """Fluorescent nuclei: Gaussian blobs at random centres."""
    img = np.zeros(shape, np.float64)
    pts = tuple(rng.integers(0, s, n) for s in shape)
    img[pts] = 1.0
    return ndimage.gaussian_filter(img, radius) * (2 * np.pi * radius**2) ** 1.5


def main(out: Path) -> None:
    out.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(32)
    vols: dict[str, tuple[np.ndarray, str]] = {}

    # connectomics-style segmentations
    vols["seg_u32"] = (
        voronoi_labels((128, 128, 128), 3000, rng, np.uint32, 2**32 - 1),
        "Voronoi of 3000 seeds, warped borders, ids random uint32 (0 = background)",
    )
    vols["seg_u64"] = (
        voronoi_labels((128, 128, 128), 3000, np.random.default_rng(64), np.uint64, 2**63),
        "the same kind, another seed, ids random below 2^63 as uint64 (neuroglancer)",
    )
    aal, _, _ = load("atlas_aal")
    ids = np.random.default_rng(7).choice(10**7, size=int(aal.max()) + 1, replace=False)
    ids[0] = 0
    vols["aal_u64"] = (ids.astype(np.uint64)[aal], "AAL atlas, labels renumbered to random ids below 1e7, uint64")
    vols["aal_u32"] = (ids.astype(np.uint32)[aal], "AAL atlas, labels renumbered to random ids below 1e7, uint32")

    # float16
    vort, _, _ = load("tgv_vorticity")
    vols["vort_f16"] = (vort.astype(np.float16), "Taylor-Green vorticity as float16")
    ch2, _, _ = load("mri_ch2")
    vols["ch2_f16"] = ((ch2.astype(np.float32) / 255).astype(np.float16), "Colin27 T1 scaled to 0..1, float16")

    # complex
    bet, _, _ = load("mri_ch2bet")
    k = np.fft.fftshift(np.fft.fftn(bet.astype(np.float32))).astype(np.complex64)
    vols["kspace_c64"] = (k, "k-space of Colin27 (skull-stripped): its 3-D FFT, complex64")

    # signed 8-bit, masks, counts
    sm = ndimage.gaussian_filter(ch2.astype(np.float32), 1.5)
    vols["hp_i8"] = (
        np.clip(np.round(ch2 - sm), -128, 127).astype(np.int8),
        "Colin27 minus its Gaussian blur (sigma 1.5), int8 (a detail band)",
    )
    vols["mask_bool"] = (bet > 0, "Colin27 brain mask (ch2bet > 0), bool")
    vols["mask_u8"] = ((bet > 0).astype(np.uint8), "the same mask as uint8 0/1")
    lam = ch2.astype(np.float64) / 255 * 20
    vols["counts_u32"] = (
        np.random.default_rng(3).poisson(lam).astype(np.uint32),
        "Poisson photon counts, rate Colin27/255*20 (0..20), uint32",
    )

    # anisotropic stacks, a 2-D image, a tiny volume
    cells = blobs((12, 1024, 1024), 1500, 3.0, rng) * 800 + 100
    vols["micro_12x1024"] = (
        rng.poisson(cells).astype(np.uint16),
        "widefield-like stack 12x1024x1024: Gaussian nuclei + Poisson noise, uint16",
    )
    ct, _, _ = load("ct_head")
    thick = ndimage.zoom(ct.astype(np.float32), (8 / ct.shape[0], 1, 1), order=1)
    vols["ct_8thick"] = (np.round(thick).astype(np.int16), "head CT resampled to 8 thick slices, int16")
    vols["ct_slice1"] = (ct[ct.shape[0] // 2][None].copy(), "one CT slice as a volume (1, 256, 256) int16")
    vols["ct_slice2d"] = (ct[ct.shape[0] // 2].copy(), "the same slice as a 2-D array (256, 256)")
    vols["tiny_f32"] = (rng.standard_normal((3, 4, 5)).astype(np.float32), "3x4x5 float32")
    vols["tiny_u8"] = (rng.integers(0, 256, (3, 4, 5)).astype(np.uint8), "3x4x5 uint8")

    # multichannel
    lut = (np.stack([np.linspace(0, 1, 256) ** g for g in (0.6, 1.0, 1.6)], 1) * 255).astype(np.uint8)
    vols["ch2_rgb_zyxc"] = (lut[ch2], "Colin27 through a colour map, (z, y, x, 3) uint8 (RGB last)")
    vols["ch2_rgb_czyx"] = (np.ascontiguousarray(np.moveaxis(lut[ch2], -1, 0)), "the same, (3, z, y, x)")
    nuc = blobs((48, 192, 192), 300, 2.5, rng)
    memb = ndimage.gaussian_gradient_magnitude(blobs((48, 192, 192), 300, 4.0, rng), 1.0)
    two = np.stack([rng.poisson(nuc * 1500 + 80), rng.poisson(memb / memb.max() * 900 + 60)], -1)
    vols["fluo2_zyxc"] = (two.astype(np.uint16), "2-channel fluorescence (nuclei, membranes) + Poisson, (z, y, x, 2) uint16")
    vols["fluo2_czyx"] = (np.ascontiguousarray(np.moveaxis(two, -1, 0)).astype(np.uint16), "the same as (2, z, y, x)")

    # borders, outliers, constants
    pad = np.zeros((256, 256, 256), np.uint8)
    pad[:bet.shape[0], :bet.shape[1], :bet.shape[2]] = bet
    vols["bet_pad256"] = (pad, "Colin27 brain padded with zeros to 256^3 (corner), uint8")
    padf = np.full((128, 128, 128), -1.0, np.float32)
    padf[32:96, 32:96, 32:96] = vort
    vols["vort_pad128"] = (padf, "vorticity padded to 128^3 with -1.0 (centred), float32")
    out1 = vort.copy()
    out1[10, 20, 30] = 1e30
    vols["vort_outlier"] = (out1, "vorticity with one voxel at 1e30, float32")
    near = (20.0 + 1e-6 * rng.standard_normal((96, 96, 96))).astype(np.float32)
    vols["nearconst_f32"] = (near, "20 + 1e-6 noise, float32 (a few ulps)")
    vols["const_f32"] = (np.full((64, 64, 64), 3.25, np.float32), "constant 3.25, float32")

    lines = []
    for name, (a, text) in vols.items():
        np.save(out / f"{name}.npy", a)
        lines.append(f"{name}\t{a.dtype}\t{'x'.join(map(str, a.shape))}\t{text}")
    (out / "volumes.txt").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main(Path(sys.argv[1]))
