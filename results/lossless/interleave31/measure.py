"""4-D MR series coded exactly: each time step alone against the series interleaved.

For every series of corpus.txt: volpack's default (which decides the layout), the two
layouts forced, and the lossless peers of ``volpack compare --peers`` on the same 4-D
array, in this process. Encode and decode CPU seconds (``time.process_time``, one
worker, kernels warmed on the first series beforehand); every volpack file decoded and
compared voxel for voxel. Writes OUT.csv, OUT.md and OUT.png.

Run: PYTHONPATH=. python results/lossless/interleave31/measure.py OUT_STEM
(``--chart`` OUT_STEM: redraw OUT.png from OUT.csv)
"""

from __future__ import annotations

import csv
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "scripts"))

from volpack import api  # noqa: E402
from volpack.compare import compare_peers  # noqa: E402

NIB = ["functional.nii", "example4d.nii.gz", "example4d+orig.HEAD",
       "phantom_EPI_asc_CLEAR_2_1.PAR", "example_nifti2.nii.gz"]  # fmt: skip
DIPY = ["small_64D.nii", "small_101D.nii.gz", "small_25.nii.gz"]


def series() -> list[tuple[str, str, np.ndarray]]:
    import fetch_data
    import nibabel

    out = []
    nib_dir = Path(nibabel.__file__).parent / "tests" / "data"
    for name in NIB:
        out.append((name, "tuned", api.read_volume(str(nib_dir / name)).data))
    dipy_dir = fetch_data._pypi_root("dipy", Path(tempfile.mkdtemp())) / "dipy" / "data" / "files"
    for name in DIPY:
        out.append((name, "held out", api.read_volume(str(dipy_dir / name)).data))
    return out


def timed(fn, *args, **kw):
    t = time.process_time()
    out = fn(*args, **kw)
    return out, time.process_time() - t


def main(stem: str) -> None:
    found = series()
    api.decompress_array(api.compress_array(found[0][2], interleave=True))  # warm-up
    api.decompress_array(api.compress_array(found[0][2], interleave=False))
    rows = []
    for name, split, a in found:
        row = {"series": name, "split": split, "shape": "x".join(map(str, a.shape)),
               "dtype": a.dtype.name, "raw": a.nbytes}  # fmt: skip
        for key, opt in (("frames", False), ("interleaved", True), ("default", None)):
            blob, enc = timed(api.compress_array, a, interleave=opt, workers=1)
            back, dec = timed(api.decompress_array, blob, workers=1)
            assert back.dtype == a.dtype and np.array_equal(back, a), (name, key)
            row[f"{key}_bytes"], row[f"{key}_enc_s"], row[f"{key}_dec_s"] = len(blob), enc, dec
            if key == "default":
                row["default_layout"] = api.info(blob)["header"].get("layout", "frames")
        peers, skipped = compare_peers(a)
        best = max(peers, key=lambda p: p["ratio"])
        row["best_peer"], row["best_peer_bytes"] = best["name"], best["file_nbytes"]
        row["peers"] = "; ".join(f"{p['name']} {p['ratio']:.3f}" for p in peers)
        row["gain"] = row["frames_bytes"] / row["interleaved_bytes"]
        row["default_x_best_peer"] = best["file_nbytes"] / row["default_bytes"]
        rows.append(row)
        print(f"{name:32s} {row['shape']:>14s} frames {row['frames_bytes']:>8d} interleaved "
              f"{row['interleaved_bytes']:>8d} ({row['gain']:.3f}x) default {row['default_layout']:>11s} "
              f"best peer {best['name']} {best['file_nbytes']} -> {row['default_x_best_peer']:.3f}x",
              flush=True)  # fmt: skip
    with open(f"{stem}.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    lines = [
        "| series | split | shape (t, z, y, x), dtype | each time step alone | interleaved | gain "
        "| default's layout | best peer | default x best peer | decode CPU s alone / interleaved |",
        "|---|---|---|---:|---:|---:|---|---|---:|---|",
    ]
    for r in rows:
        lines.append(
            f"| {r['series']} | {r['split']} | {r['shape']} {r['dtype']} | "
            f"{r['raw'] / r['frames_bytes']:.3f} | {r['raw'] / r['interleaved_bytes']:.3f} | "
            f"{r['gain']:.3f}x | {r['default_layout']} | {r['best_peer']} "
            f"{r['raw'] / r['best_peer_bytes']:.3f} | {r['default_x_best_peer']:.3f} | "
            f"{r['frames_dec_s']:.3f} / {r['interleaved_dec_s']:.3f} |"
        )
    Path(f"{stem}.md").write_text("\n".join(lines) + "\n")
    chart(rows, f"{stem}.png")


def chart(rows: list[dict], path: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = [r["series"].split(".")[0] for r in rows]
    x = np.arange(len(rows))
    fig, ax = plt.subplots(figsize=(10, 4))
    for i, (key, label) in enumerate(
        (("frames_bytes", "volpack, each time step alone"),
         ("interleaved_bytes", "volpack, interleaved"),
         ("best_peer_bytes", "best peer"))
    ):  # fmt: skip
        ax.bar(x + (i - 1) * 0.27, [r["raw"] / r[key] for r in rows], 0.27, label=label)
    ax.set_xticks(x, names, rotation=20, ha="right")
    ax.set_ylabel("lossless ratio")
    ax.set_title("4-D series coded exactly: volpack's two layouts and the best peer")
    ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=120)


if __name__ == "__main__":
    if len(sys.argv) == 3 and sys.argv[1] == "--chart":
        with open(f"{sys.argv[2]}.csv") as f:
            rows = [{k: (float(v) if k.endswith("bytes") or k == "raw" else v) for k, v in r.items()}
                    for r in csv.DictReader(f)]  # fmt: skip
        chart(rows, f"{sys.argv[2]}.png")
    elif len(sys.argv) != 2:
        sys.exit(__doc__)
    else:
        main(sys.argv[1])
