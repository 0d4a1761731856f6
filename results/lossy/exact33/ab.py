"""The exact path's zstd stand-in (lossy.EXACT_PROXY) on and off, in one process.

For every float field of scripts/datasets.py (and, as held-out shapes, each taken at
every second voxel), whole volumes up to 3 M voxels, at 1e-3, 1e-4 and 1e-5 of the value
range: the default effort's file with ``EXACT_PROXY = 0`` (before) and its value
(after), one worker, CPU seconds of each encode; every file decoded and its bound
checked on every voxel; where the bytes differ, the bounded peers of ``volpack compare
--peers`` (SZ3, SPERR point-wise) on the same array. Writes OUT.csv.

Run: PYTHONPATH=. python results/lossy/exact33/ab.py OUT.csv [NAMES]
"""

from __future__ import annotations

import csv
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "scripts"))

from datasets import DATASETS, load  # noqa: E402

from volpack import api  # noqa: E402
from volpack.compare import compare_peers  # noqa: E402
from volpack.volume_codec import lossy  # noqa: E402

BOUNDS = (1e-3, 1e-4, 1e-5)
ON = lossy.EXACT_PROXY


def encode(a: np.ndarray, rel: float, proxy: float) -> tuple[bytes, float]:
    lossy.EXACT_PROXY = proxy
    t = time.process_time()
    blob = api.compress_array(a, rel_error=rel, workers=1)
    return blob, time.process_time() - t


def main(out: str, names: list[str]) -> None:
    rows = []
    for name in [names[0], *names]:  # the first field twice: its first pass compiles
        v = np.asarray(load(name)[0])
        for kind, a in (("whole", v), ("every 2nd", v[::2, ::2, ::2])):
            a = np.ascontiguousarray(a, dtype=a.dtype if a.dtype.kind == "f" else np.float32)
            if a.size > 3_000_000:
                continue
            span = float(np.nanmax(a)) - float(np.nanmin(a))
            for rel in BOUNDS:
                e = rel * span
                before, t0 = encode(a, rel, 0.0)
                after, t1 = encode(a, rel, ON)
                for blob in (before, after):
                    back = api.decompress_array(blob)
                    ok = np.isfinite(a)
                    err = np.abs(back[ok].astype(np.float64) - a[ok].astype(np.float64)).max()
                    assert err <= e, (name, kind, rel, err, e)
                row = {"field": name, "kind": kind, "shape": "x".join(map(str, a.shape)),
                       "rel": rel, "before": len(before), "after": len(after),
                       "gain": round(len(before) / len(after), 4),
                       "cpu_before": round(t0, 3), "cpu_after": round(t1, 3)}  # fmt: skip
                if len(before) != len(after):
                    peers, _ = compare_peers(a, max_error=e)
                    held = [
                        p for p in peers if p.get("bound_held") and p["name"] in ("sz3", "sperr")
                    ]
                    best = min(held, key=lambda p: p["file_nbytes"])
                    row.update(
                        peer=best["name"],
                        peer_bytes=best["file_nbytes"],
                        x_before=round(best["file_nbytes"] / len(before), 4),
                        x_after=round(best["file_nbytes"] / len(after), 4),
                    )
                print(row, flush=True)
                rows.append(row)
    rows = rows[sum(r["field"] == names[0] for r in rows) // 2 :]  # less the first pass
    keys = list(dict.fromkeys(k for r in rows for k in r))
    with open(out, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=keys)
        w.writeheader()
        w.writerows(rows)


if __name__ == "__main__":
    floats = [n for n, d in DATASETS.items() if d.kind == "float"]
    main(sys.argv[1], sys.argv[2].split(",") if len(sys.argv) > 2 else floats)
