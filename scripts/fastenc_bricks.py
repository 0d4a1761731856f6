"""Collect the bricks ``FastCodec.encode`` gets when a volume is compressed: lossless
``--codec fast`` on integer scans, the quantised voxels of lossy ``--effort fast`` on
float fields (as ``BoundedCodec._code_quantised`` hands them over). Saved as one ``.npz``
a volume/setting, for :mod:`fastenc_compare` (same bytes, encode speed against main).

    python scripts/fastenc_bricks.py OUTDIR
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import datasets  # noqa: E402

from volpack import api  # noqa: E402
from volpack.volume_codec.fast import FastCodec  # noqa: E402

LOSSLESS = ["ct_head", "mri_ch2better", "brainsmall", "liver_labels", "atlas_aal"]
LOSSY = [
    ("tgv_u", 1e-3),
    ("tgv_u", 1e-4),
    ("cam_t", 1e-3),
    ("cam_t", 1e-4),
    ("md_water", 1e-3),
    ("md_water", 1e-4),
    ("eta_u", 1e-3),
    ("xray_1jzv", 1e-4),
]


def capture(x: np.ndarray, opts: dict) -> tuple[list[np.ndarray], list[bool]]:
    """The bricks (and each call's ``zstd`` option) ``FastCodec.encode`` sees when ``x``
    is compressed with ``opts`` on one worker."""
    seen, zs = [], []
    orig = FastCodec.encode

    def spy(self, brick):
        seen.append(np.array(brick))
        zs.append(self.zstd)
        return orig(self, brick)

    FastCodec.encode = spy
    try:
        api.compress_array(x, workers=1, **opts)
    finally:
        FastCodec.encode = orig
    return seen, zs


def main() -> None:
    out = Path(sys.argv[1])
    out.mkdir(parents=True, exist_ok=True)
    jobs = [(n, None) for n in LOSSLESS] + LOSSY
    for name, rel in jobs:
        try:
            x, _, _ = datasets.load(name)
        except Exception as e:  # a volume missing from the cache is skipped, said so
            print(f"{name}: skipped ({e})")
            continue
        if rel is None:
            opts, tag = {"codec": "fast"}, name
        else:
            rng = float(np.nanmax(x)) - float(np.nanmin(x))
            opts, tag = {"max_error": rel * rng, "effort": "fast"}, f"{name}@{rel:g}"
        bricks, zs = capture(x, opts)
        arrs = {f"b{i}": b for i, b in enumerate(bricks)}
        np.savez(out / f"{tag}.npz", zstd=np.array(zs), **arrs)
        print(
            f"{tag}: {len(bricks)} bricks, {sum(b.size for b in bricks)} voxels, "
            f"dtypes {sorted({str(b.dtype) for b in bricks})}, zstd {set(zs)}"
        )


if __name__ == "__main__":
    main()
