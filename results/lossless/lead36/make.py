"""Session 36's small trial (the lead): four copies of real volumes, kinds no trial had.

    python results/lossless/lead36/make.py OUT    # writes OUT/*.npy
    volpack -q compare OUT/F.npy --peers --jpegxl-efforts 7,9 --json          # lossless
    volpack -q compare OUT/F.npy --rel-error E --peers --json                 # E = 1e-2, 1e-4
"""

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[3] / "scripts"))
import datasets  # noqa: E402


def main(out: Path) -> None:
    out.mkdir(parents=True, exist_ok=True)
    ct = datasets.load("ct_head")[0]
    np.save(out / "ct_f32.npy", ct.astype(np.float32))  # integer values stored as floats
    mni = datasets.load("mri_mni152")[0]  # brightened until most tissue saturates
    np.save(out / "mni_sat.npy", np.clip(mni.astype(np.float64) * 2.5, 0, 255).astype(np.uint8))
    atlas = datasets.load("atlas_harvardoxford")[0]  # labels stored as float32
    np.save(out / "atlas_f32.npy", atlas.astype(np.float32))
    nuclei = datasets.load("nuclei_stardist")[0]  # the top 3 % saturated at 65535
    top = np.percentile(nuclei, 97)
    scaled = np.clip(nuclei.astype(np.float64) * (65535 / top), 0, 65535)
    np.save(out / "nuclei_sat.npy", scaled.astype(np.uint16))


if __name__ == "__main__":
    main(Path(sys.argv[1]))
