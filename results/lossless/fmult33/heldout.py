"""Held-out float volumes for the lattice step from the values of least magnitude: the
synthetic fields of results/unseen26 and results/unseen28 (made by their make.py in
DIR), and from real volumes of scripts/datasets.py made here: Poisson counts at the
Colin27 MRI's intensity times 0.0123 (in float32, and with a third of the voxels through
another path: ``k / (1 / c) * (1 + 2e-6)``), and the NCL air temperature packed to int16
and unpacked in float32 arithmetic (``k * scale + offset``). Both settings in one process,
bit-exact round trips, the best lossless peer where the bytes differ. Writes OUT.csv.

Run: PYTHONPATH=. python results/lossless/fmult33/heldout.py DIR OUT.csv
"""

import csv
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[3] / "scripts"))
sys.path.insert(0, str(Path(__file__).resolve().parent))
from ab import encode  # noqa: E402
from datasets import load  # noqa: E402

from volpack.compare import compare_peers  # noqa: E402


def volumes(folder: Path) -> dict[str, np.ndarray]:
    vols = {p.stem: np.load(p) for p in sorted(folder.glob("*.npy")) if np.load(p).dtype.kind == "f"}
    rng = np.random.default_rng(33)
    ch2 = load("mri_ch2")[0].astype(np.float64)
    k = rng.poisson(ch2)
    c = np.float32(0.0123)
    counts = (k * c).astype(np.float32)
    vols["ch2_counts_x_c"] = counts
    two = counts.copy()
    other = rng.random(k.shape) < 0.3
    two[other] = k[other].astype(np.float32) / np.float32(1 / c) * np.float32(1.000002)
    vols["ch2_counts_two_paths"] = two
    t = load("climate_t")[0].astype(np.float64)
    scale, offset = (t.max() - t.min()) / 65000, (t.max() + t.min()) / 2
    q = np.rint((t - offset) / scale).astype(np.int16)
    vols["climate_t_unpacked"] = q.astype(np.float32) * np.float32(scale) + np.float32(offset)
    return vols


def main(folder: str, out: str) -> None:
    rows = []
    for name, a in volumes(Path(folder)).items():
        a = np.ascontiguousarray(a)
        before, t0 = encode(a, False)
        after, t1 = encode(a, True)
        row = {"volume": name, "shape": "x".join(map(str, a.shape)), "dtype": a.dtype.name,
               "before": len(before), "after": len(after), "gain": round(len(before) / len(after), 4),
               "cpu_before": round(t0, 3), "cpu_after": round(t1, 3)}  # fmt: skip
        peers, _ = compare_peers(a, jpegxl_efforts=())
        best = max(peers, key=lambda p: p["ratio"])
        row.update(peer=best["name"], x_before=round(a.nbytes / len(before) / best["ratio"], 4),
                   x_after=round(a.nbytes / len(after) / best["ratio"], 4))  # fmt: skip
        print(row, flush=True)
        rows.append(row)
    with open(out, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
