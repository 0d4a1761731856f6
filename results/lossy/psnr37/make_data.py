"""The psnr37 fields as .npy files: kinds37's float makers (their seeds, 3700 + the maker's
index in make.py), qmc_orb4d reshaped to 3-D, and two corpus fields.

    PYTHONPATH=. python results/lossy/psnr37/make_data.py DIR
"""

import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[3]
sys.path[:0] = [str(ROOT / "results" / "kinds37"), str(ROOT / "scripts")]

import datasets  # noqa: E402
import make  # noqa: E402

KINDS = ("miranda_visc", "nyx_vel", "nyx_temp", "isabel_pfill", "isabel_qcloud", "s3d_oh64",
         "s3d_temp64", "qmc_orb4d")  # fmt: skip
CORPUS = ("dwi_piesno_float", "grid3d_var3")


def main() -> None:
    d = Path(sys.argv[1])
    d.mkdir(parents=True, exist_ok=True)
    for i, name in enumerate(make.MAKERS):
        if name in KINDS:
            a = make.MAKERS[name](np.random.default_rng(3700 + i))
            if name == "qmc_orb4d":  # TTHRESH's wasm decoder traps on the 4-D array
                name, a = "qmc_orb3d", np.ascontiguousarray(a.reshape(-1, *a.shape[2:]))
            np.save(d / f"{name}.npy", a)
            print(name, a.shape, a.dtype, flush=True)
    for name in CORPUS:
        a = datasets.load(name)[0]
        np.save(d / f"{name}.npy", a)
        print(name, a.shape, a.dtype, flush=True)


if __name__ == "__main__":
    main()
