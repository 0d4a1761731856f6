"""Colour volumes for the tuple palette (cpal33): scans of scripts/datasets.py through
matplotlib colour maps, a label atlas in random colours, an RGBA transfer function.

    from make import volumes; vols = volumes()   # {name: (array, description)}

``ch2_rgb_zyxc`` is session 32's volume (results/cli/user32/make.py), the one the change
was tuned on; every other is held out (made after the code was written, not tuned on).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[3] / "scripts"))
from datasets import load  # noqa: E402


def lut(name: str, alpha: bool = False) -> np.ndarray:
    """A matplotlib colour map as a (256, 3 or 4) uint8 table."""
    from matplotlib import colormaps

    t = colormaps[name](np.arange(256))
    return np.round(t[:, : 4 if alpha else 3] * 255).astype(np.uint8)


def to_u8(a: np.ndarray, lo: float, hi: float) -> np.ndarray:
    """``a`` windowed to ``[lo, hi]`` and scaled to 0..255 (a viewer's 8-bit display)."""
    return np.round(np.clip((a.astype(np.float64) - lo) / (hi - lo), 0, 1) * 255).astype(np.uint8)


def tuned() -> dict[str, tuple[np.ndarray, str]]:
    ch2, _, _ = load("mri_ch2")
    gam = (np.stack([np.linspace(0, 1, 256) ** g for g in (0.6, 1.0, 1.6)], 1) * 255).astype(np.uint8)
    return {"ch2_rgb_zyxc": (gam[ch2], "Colin27 through gamma 0.6/1/1.6 (session 32's), RGB last")}


def held_out() -> dict[str, tuple[np.ndarray, str]]:
    out = {}
    ct, _, _ = load("ct_head")
    out["ct_viridis"] = (lut("viridis")[to_u8(ct, -1000, 2000)], "head CT, window -1000..2000, viridis, RGB last")
    mni, _, _ = load("mri_mni152")
    out["mni_turbo"] = (lut("turbo")[mni], "MNI152 T1 through turbo (non-monotone luminance), RGB last")
    out["mni_turbo_czyx"] = (
        np.ascontiguousarray(np.moveaxis(lut("turbo")[mni], -1, 0)), "the same, channels first (3, z, y, x)"
    )
    itk, _, _ = load("mri_itk_t1")
    g = to_u8(itk, 0, 255)
    out["itk_grey"] = (np.stack([g, g, g], -1), "ITK T1 through a grey map (r = g = b), RGB last")
    bs, _, _ = load("brainsmall")
    out["brainsmall_coolwarm"] = (lut("coolwarm")[to_u8(bs, 0, 202)], "brainsmall through coolwarm (diverging), RGB last")
    aal, _, _ = load("atlas_aal")
    colours = np.random.default_rng(33).integers(0, 256, (int(aal.max()) + 1, 3)).astype(np.uint8)
    colours[0] = 0
    out["aal_random_rgb"] = (colours[aal], "AAL atlas, a random colour per label (segmentation overlay), RGB last")
    bet, _, _ = load("mri_ch2bet")
    rgba = lut("plasma", alpha=True)
    rgba[:, 3] = np.minimum(255, 3 * np.arange(256))  # an opacity ramp, as a transfer function
    out["bet_plasma_rgba"] = (rgba[to_u8(bet, 0, 133)], "skull-stripped Colin27 through plasma + opacity ramp, RGBA last")
    ch2, _, _ = load("mri_ch2")
    blend = np.stack([ch2] * 3, -1).astype(np.float64)
    lab = aal > 0
    blend[lab] = 0.5 * blend[lab] + 0.5 * colours[aal[lab]]
    out["ch2_aal_overlay"] = (np.round(blend).astype(np.uint8), "Colin27 grey with the AAL labels blended in at 50 %, RGB last")
    return out


def held_out_late() -> dict[str, tuple[np.ndarray, str]]:
    """Made after the code was final (23:35 UTC) from scans and maps not used before:
    held_out()'s volumes were seen while the candidate orders were compared (the settled
    order was added after mni_turbo, itk_grey, ct_viridis and ch2_aal_overlay); these
    were not."""
    out = {}
    s0, _, _ = load("mri_dipy_s0")
    out["s0_hot"] = (lut("hot")[to_u8(s0, 0, float(np.percentile(s0, 99.5)))], "dipy S0 slab through hot, RGB last")
    inia, _, _ = load("mri_inia19_float")
    out["inia19_twilight"] = (lut("twilight")[to_u8(inia, 0, 383.2)], "INIA19 primate T1 through twilight (cyclic), RGB last")
    jhu, _, _ = load("atlas_jhu_wm")
    colours = np.random.default_rng(44).integers(0, 256, (int(jhu.max()) + 1, 4)).astype(np.uint8)
    colours[:, 3] = 200
    colours[0] = 0
    out["jhu_random_rgba"] = (colours[jhu], "JHU white-matter labels, random colours, alpha 200 (0 outside), RGBA last")
    aniso, _, _ = load("mri_dipy_aniso")
    out["aniso_magma_czyx"] = (
        np.ascontiguousarray(np.moveaxis(lut("magma")[to_u8(aniso, 0, 2149)], -1, 0)),
        "dipy anisotropic-voxel scan through magma, channels first (3, z, y, x)",
    )
    km, _, _ = load("labels_itk_kmeans")
    out["kmeans_tab10"] = (lut("tab10")[km], "ITK k-means classes through tab10, RGB last")
    return out


def volumes() -> dict[str, tuple[np.ndarray, str]]:
    return {**tuned(), **held_out(), **held_out_late()}


if __name__ == "__main__":
    for name, (a, text) in volumes().items():
        k = len(np.unique(a.reshape(-1, a.shape[-1]) if a.shape[-1] <= 4 else np.moveaxis(a, 0, -1).reshape(-1, a.shape[0]), axis=0))
        print(name, a.dtype, a.shape, "tuples", k, "-", text)
