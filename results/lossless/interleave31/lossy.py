"""4-D series under an error bound: each time step alone against interleaved, and the peers.

For every series of measure.py and heldout.py (the two large held-out ones cut to a
corner of a few million voxels) and rel_error E = 1e-2, 1e-3, 1e-4 of the value range:
volpack with `interleave=False`, `True` and the default, each file decoded and its bound
checked on every voxel; the bounded peers of `volpack compare --peers` (SZ3 and zfp on
the 4-D array, SPERR where it takes it) on the same array in this process, their bound
checked too. Writes OUT.csv and OUT.md.

Run: PYTHONPATH=. python results/lossless/interleave31/lossy.py OUT_STEM
"""

from __future__ import annotations

import csv
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))

import heldout  # noqa: E402
import measure  # noqa: E402

from volpack import api  # noqa: E402
from volpack.compare import compare_peers  # noqa: E402

BOUNDS = (1e-2, 1e-3, 1e-4)
CUTS = {  # the large held-out series, cut (time steps whole)
    "perfusion": (slice(None), slice(8, 24), slice(64, 192), slice(64, 192)),
    "dwi": (slice(None), slice(5, 15), slice(50, 150), slice(40, 140)),
    "us_cine_rgb": (slice(0, 20),),
}


def worst(a: np.ndarray, b: np.ndarray) -> float:
    ok = np.isfinite(a)
    return float(np.abs(b[ok].astype(np.float64) - a[ok].astype(np.float64)).max())


def main(stem: str) -> None:
    found = measure.series() + heldout.series()
    rows = []
    for name, split, a in found:
        a = np.ascontiguousarray(a[CUTS.get(name, (slice(None),))])
        span = float(np.nanmax(a)) - float(np.nanmin(a))
        for rel in BOUNDS:
            e = rel * span
            row = {"series": name, "split": split, "shape": "x".join(map(str, a.shape)),
                   "dtype": a.dtype.name, "rel": rel, "bound": e, "raw": a.nbytes}  # fmt: skip
            for key, opt in (("frames", False), ("interleaved", True), ("default", None)):
                blob = api.compress_array(a, rel_error=rel, interleave=opt, workers=1)
                back = api.decompress_array(blob)
                assert worst(a, back) <= e, (name, rel, key)
                row[f"{key}_bytes"] = len(blob)
                if key == "default":
                    row["default_layout"] = api.info(blob)["header"].get("layout", "frames")
            peers, skipped = compare_peers(a, max_error=e)
            held = [p for p in peers if p.get("bound_held")]
            best = max(held, key=lambda p: p["ratio"])
            row["best_peer"], row["best_peer_bytes"] = best["name"], best["file_nbytes"]
            row["peers"] = "; ".join(
                f"{p['name']} {p['ratio']:.3f}{'' if p.get('bound_held') else ' (bound missed)'}"
                for p in peers
            )
            row["gain"] = row["frames_bytes"] / row["interleaved_bytes"]
            row["default_x_best_peer"] = best["file_nbytes"] / row["default_bytes"]
            rows.append(row)
            print(f"{name:30s} {rel:g} frames {row['frames_bytes']:>9d} interleaved "
                  f"{row['interleaved_bytes']:>9d} ({row['gain']:.3f}x) default "
                  f"{row['default_layout']:>11s} best {best['name']} {best['file_nbytes']} -> "
                  f"{row['default_x_best_peer']:.3f}x", flush=True)  # fmt: skip
    with open(f"{stem}.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    lines = [
        "| series | split | shape, dtype | E / range | each alone | interleaved | gain "
        "| default's layout | best peer | default x best peer |",
        "|---|---|---|---:|---:|---:|---:|---|---|---:|",
    ]
    for r in rows:
        lines.append(
            f"| {r['series']} | {r['split']} | {r['shape']} {r['dtype']} | {r['rel']:g} | "
            f"{r['raw'] / r['frames_bytes']:.2f} | {r['raw'] / r['interleaved_bytes']:.2f} | "
            f"{r['gain']:.3f}x | {r['default_layout']} | {r['best_peer']} "
            f"{r['raw'] / r['best_peer_bytes']:.2f} | {r['default_x_best_peer']:.3f} |"
        )
    Path(f"{stem}.md").write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    main(sys.argv[1])
