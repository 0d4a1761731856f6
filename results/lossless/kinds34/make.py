"""Volumes of kinds the corpus lacks, made from its real volumes (session 34, kinds34), seeded.

    PYTHONPATH=. python results/lossless/kinds34/make.py DIR

Writes DIR/NAME.npy and DIR/volumes.txt (name, set, dtype and shape, description). The
set ("tuned" or "held") was written down before any volpack run: one volume of each kind
is held out (no tuning looks at it).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
from scipy import ndimage

sys.path.insert(0, str(Path(__file__).resolve().parents[3] / "scripts"))
from datasets import load  # noqa: E402

SEED = 34


def head_mask(a: np.ndarray, level: float) -> np.ndarray:
    """The head: voxels above level, closed, holes filled, the largest component."""
    m = ndimage.binary_closing(a > level, iterations=3)
    m = ndimage.binary_fill_holes(m)
    lab, n = ndimage.label(m)
    sizes = ndimage.sum(m, lab, range(1, n + 1))
    return lab == 1 + int(np.argmax(sizes))


def mode_down2(lab: np.ndarray) -> np.ndarray:
    """Downsample a label map by 2 per axis: the most frequent label of each 2x2x2 block
    (ties: the smallest label)."""
    z, y, x = (s // 2 * 2 for s in lab.shape)
    b = lab[:z, :y, :x].reshape(z // 2, 2, y // 2, 2, x // 2, 2).transpose(0, 2, 4, 1, 3, 5)
    b = np.sort(b.reshape(z // 2, y // 2, x // 2, 8), axis=-1)
    best = b[..., 0].copy()
    count = np.zeros(best.shape, np.int32)
    for i in range(8):
        c = (b == b[..., i : i + 1]).sum(-1)
        take = c > count
        best[take], count[take] = b[..., i][take], c[take]
    return best


def grid_split(lab: np.ndarray, step: int) -> np.ndarray:
    """Every region split by a coarse grid of `step` voxels, renumbered 1.. in scan order."""
    cell = np.zeros(lab.shape, np.int64)
    for ax, n in enumerate(lab.shape):
        idx = (np.arange(n) // step).reshape([-1 if i == ax else 1 for i in range(3)])
        cell = cell * ((n + step - 1) // step) + idx
    key = np.where(lab > 0, lab.astype(np.int64) * (1 << 40) + cell, -1)
    _, inv = np.unique(key, return_inverse=True)
    out = inv.reshape(lab.shape)  # 0 is the background's -1
    return out.astype(np.uint16)


def volumes():
    """(name, set, description, array) of every volume."""
    rng = np.random.default_rng(SEED)
    ct = load("ct_head")[0]
    ch2 = load("mri_ch2")[0]
    gm = load("mni152_gm")[0]
    wm = load("mni152_wm")[0]
    aal = load("atlas_aal")[0]
    aicha = load("atlas_aicha")[0]
    ch2better = load("mri_ch2better")[0]
    bet = load("mri_ch2bet")[0]
    out = []

    def add(name, kind, text, a):
        out.append((name, kind, text, np.ascontiguousarray(a)))

    # probability maps: uint16 0..10000 (a uint8 map rescaled: a lattice of step 39.2) and
    # a smoothed map at full uint16 precision; a smoothed map as uint8 0..255
    add(
        "gm_u16",
        "tuned",
        "MNI152 GM map x 10000/255 (uint16 0..10000)",
        np.round(gm * (10000 / 255)).astype(np.uint16),
    )
    add(
        "wm_u16s",
        "held",
        "MNI152 WM map Gaussian-smoothed (sigma 1) x 10000/255, uint16",
        np.round(ndimage.gaussian_filter(wm.astype(np.float64), 1.0) * (10000 / 255)).astype(
            np.uint16
        ),
    )
    add(
        "gm_u8s",
        "tuned",
        "MNI152 GM map Gaussian-smoothed (sigma 2), uint8 0..255",
        np.round(ndimage.gaussian_filter(gm.astype(np.float64), 2.0)).astype(np.uint8),
    )
    # distance transforms
    brain = bet > 0
    add(
        "edt_u16",
        "tuned",
        "Euclidean distance inside ch2bet's brain mask x 10, uint16",
        np.round(ndimage.distance_transform_edt(brain) * 10).astype(np.uint16),
    )
    inside = aal > 0
    sd = ndimage.distance_transform_edt(inside) - ndimage.distance_transform_edt(~inside)
    add(
        "sdt_i16",
        "held",
        "signed distance to the AAL atlas' brain boundary x 10, int16",
        np.round(sd * 10).astype(np.int16),
    )
    # gradient magnitude of the CT
    f = ct.astype(np.float64)
    g = np.sqrt(sum(ndimage.sobel(f, axis=i) ** 2 for i in range(3)))
    add(
        "ctgrad_i16",
        "tuned",
        "head CT Sobel gradient magnitude / 8, int16",
        np.round(np.minimum(g / 8, 32767)).astype(np.int16),
    )
    # label maps: blocky 2x upsampling, mode downsampling, many small regions
    add(
        "aicha_up2",
        "tuned",
        "AICHA atlas upsampled 2x by nearest neighbour, uint8",
        aicha.repeat(2, 0).repeat(2, 1).repeat(2, 2),
    )
    add("aal_down2", "held", "AAL atlas downsampled by 2 (mode of 2x2x2), uint8", mode_down2(aal))
    add(
        "aal_grid_u16",
        "tuned",
        "AAL regions split by a 6-voxel grid, renumbered, uint16",
        grid_split(aal, 6),
    )
    # difference images
    m = ndimage.uniform_filter(ch2.astype(np.float64), 3, mode="nearest")
    add(
        "ch2_diff_i16",
        "tuned",
        "Colin27 T1 minus its 3x3x3 mean (rounded), int16",
        np.round(ch2 - m).astype(np.int16),
    )
    m = ndimage.uniform_filter(f, 3, mode="nearest")
    add(
        "ct_diff_i16",
        "held",
        "head CT minus its 3x3x3 mean (rounded), int16",
        np.round(f - m).astype(np.int16),
    )
    # low counts
    lam = ndimage.gaussian_filter(ch2.astype(np.float64), 2.0)
    add(
        "poisson5_u16",
        "tuned",
        "Poisson counts of the blurred Colin27 T1 scaled to 0..5, uint16",
        rng.poisson(lam * (5 / lam.max())).astype(np.uint16),
    )
    lam = ndimage.gaussian_filter(bet.astype(np.float64), 2.0) * (40 / bet.max())
    keep = rng.random(bet.shape) < 0.01 / max((bet > 0).mean(), 1e-9)
    add(
        "sparse_u16",
        "held",
        "Poisson counts (0..40 expected) of the blurred brain on 1 % of voxels, uint16",
        np.where(keep & (bet > 0), rng.poisson(lam), 0).astype(np.uint16),
    )
    # elongated cuts
    add(
        "long_z",
        "tuned",
        "Colin27 0.5 mm T1, a 316x24x24 column along z, uint8",
        ch2better[:, 170:194, 140:164],
    )
    add("long_x", "held", "head CT, a 24x24x256 rod along x, int16", ct[50:74, 120:144, :])
    # reduced bit depth
    q = np.round((f - f.min()) * (1023 / (f.max() - f.min())))
    add("ct10_u16", "tuned", "head CT requantised to 0..1023, uint16", q.astype(np.uint16))
    add(
        "ch2_x4_u16",
        "held",
        "Colin27 T1 x 4 (a bit-depth-raised copy: gaps of 4), uint16",
        ch2.astype(np.uint16) * 4,
    )
    # a constant non-zero background
    hm = head_mask(ch2, 20)
    add(
        "ch2_bg1000",
        "tuned",
        "Colin27 T1, +1000 outside the head (mask by threshold 20), uint16",
        np.where(hm, ch2, ch2.astype(np.uint16) + 1000).astype(np.uint16),
    )
    hm = head_mask(f, -500)
    add(
        "ct_bg3000",
        "held",
        "head CT, air outside the head set to 3000, int16",
        np.where(hm, ct, 3000).astype(np.int16),
    )
    # a mosaic (one 2-D image of tiled slices, as scanners export EPI)
    s0 = load("mri_dipy_s0")[0]
    add(
        "s0_mosaic",
        "tuned",
        "dipy b0 (10 slices of 128^2) tiled 2x5 into a 1x256x640 mosaic, uint16",
        s0.reshape(2, 5, 128, 128).transpose(0, 2, 1, 3).reshape(1, 256, 640),
    )
    return out  # fmt: skip


def main(d: Path) -> None:
    d.mkdir(parents=True, exist_ok=True)
    lines = []
    for name, kind, text, a in volumes():
        np.save(d / f"{name}.npy", a)
        lines.append(f"{name}\t{kind}\t{a.dtype} {'x'.join(map(str, a.shape))}\t{text}")
        print(lines[-1], int(a.min()), int(a.max()), len(np.unique(a)), flush=True)
    (d / "volumes.txt").write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main(Path(sys.argv[1]))
