"""A/B of the shared rANS tables (bounded_interp.SHARED_TABLES off = before, on = after)
in one process: bytes, every voxel checked against the bound (after; before too), decode
CPU s (best of 3) of each stream, encode CPU s.

Run: PYTHONPATH=. python results/lossy/lossy35/ab.py OUT.csv SPEC [RELS] [EFFORT]
SPEC: comma-separated .npy paths, or names of scripts/datasets.py ("corpus": every float
field). RELS default 1e-2,1e-3,1e-4,1e-5 (of the finite value range).
"""

from __future__ import annotations

import csv
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "scripts"))

from datasets import load, names  # noqa: E402

from volpack import api  # noqa: E402
from volpack.volume_codec import bounded_interp as bi  # noqa: E402


def arrays(spec: str):
    for s in spec.split(","):
        if s == "corpus":
            for n in names(kinds=("float",)):
                yield n, np.ascontiguousarray(load(n)[0])
        elif s.endswith(".npy"):
            yield Path(s).stem, np.load(s)
        else:
            yield s, np.ascontiguousarray(load(s)[0])


def best_cpu(f, n=3):
    t = []
    for _ in range(n):
        t0 = time.process_time()
        out = f()
        t.append(time.process_time() - t0)
    return out, min(t)


def main() -> None:
    out, spec = sys.argv[1], sys.argv[2]
    rels = [float(r) for r in (sys.argv[3] if len(sys.argv) > 3 else "1e-2,1e-3,1e-4,1e-5").split(",")]
    effort = sys.argv[4] if len(sys.argv) > 4 else "default"
    rows = []
    for name, x in arrays(spec):
        fin = np.isfinite(x)
        lo, hi = float(x[fin].min()), float(x[fin].max())
        for rel in rels:
            row = {"field": name, "rel": rel}
            for tag, on in (("before", False), ("after", True)):
                bi.SHARED_TABLES = on
                t0 = time.process_time()
                blob = api.compress_array(x, rel_error=rel, workers=1, effort=effort)
                row[f"enc_s_{tag}"] = round(time.process_time() - t0, 3)
                y, dec = best_cpu(lambda b=blob: api.decompress_array(b, workers=1))
                err = float(np.abs(y[fin].astype(np.float64) - x[fin].astype(np.float64)).max())
                assert err <= rel * (hi - lo), (name, rel, tag, err)
                assert np.array_equal(np.isnan(y), np.isnan(x))
                row[f"bytes_{tag}"] = len(blob)
                row[f"dec_s_{tag}"] = round(dec, 5)
            row["x_bytes"] = round(row["bytes_before"] / row["bytes_after"], 4)
            print(row, flush=True)
            rows.append(row)
    with open(out, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    changed = [r for r in rows if r["bytes_before"] != r["bytes_after"]]
    print(f"{len(rows)} cells, {len(changed)} changed, {sum(r['x_bytes'] < 1 for r in rows)} grew")


if __name__ == "__main__":
    main()
