"""Thin bricks for large thin float fields under a bound (bricks.default_brick), before
and after in one process: before = ``bricks.THIN_SLICES = 0`` (the 128^3 bricks of
10dcf4d, which cut a 2-D field into 128^2 tiles), after = today's default. Bytes, encode
and decode CPU seconds (best of REPEAT, second decode on), every voxel checked, and the
best of SZ3/SPERR point-wise on the same array (peers.bounded).

Fields (synthetic, labelled; no real 2-D field past 4 M voxels was found offline): seeded
Gaussian random fields of the CESM-ATM grid 1800x3600 (power slopes -3 and -4) and a
2-slice 1500x1500 stack; and the real 1201x2401 topography of libncarg-data's
cdf/trinidad.nc (2.9 M voxels, coded whole by both) with before = 128^3 bricks forced.

Run: PYTHONPATH=. python results/lossy/flat34/ab.py OUT.csv
"""

from __future__ import annotations

import csv
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from trial import NCARG, grf  # noqa: E402

from volpack import api, peers  # noqa: E402
from volpack.volume_codec import bricks  # noqa: E402

BOUNDS = (1e-2, 1e-3, 1e-4, 1e-5)
REPEAT = 2


def fields():
    yield "grf_s3_1800x3600 (synthetic)", grf((1800, 3600), -3.0, 2)[None]
    yield "grf_s4_1800x3600 (synthetic)", grf((1800, 3600), -4.0, 3)[None]
    yield (
        "grf_s4_2x1500x1500 (synthetic)",
        np.stack([grf((1500, 1500), -4.0, 4), grf((1500, 1500), -4.0, 5)]),
    )
    import netCDF4

    t = netCDF4.Dataset(NCARG / "cdf/trinidad.nc").variables["data"][:]
    yield "trinidad_topo 1201x2401 (real)", np.asarray(t, np.float32)[None]


def run(a, rel, old: bool, forced):
    saved = bricks.THIN_SLICES
    bricks.THIN_SLICES = 0 if old else saved
    try:
        enc = dec = np.inf
        for _ in range(REPEAT):
            t = time.process_time()
            blob = api.compress_array(a, rel_error=rel, workers=1, brick=forced if old else None)
            enc = min(enc, time.process_time() - t)
        api.decompress_array(blob, workers=1)
        for _ in range(REPEAT):
            t = time.process_time()
            back = api.decompress_array(blob, workers=1)
            dec = min(dec, time.process_time() - t)
    finally:
        bricks.THIN_SLICES = saved
    e = rel * (float(a.max()) - float(a.min()))
    assert float(np.abs(back.astype(np.float64) - a).max()) <= e
    return blob, enc, dec


def main(out: str) -> None:
    rows = []
    for label, a in fields():
        forced = (128, 128, 128) if a.size <= bricks.LOSSY_FLOAT_VOXELS else None
        for rel in BOUNDS:
            old, eo, do = run(a, rel, True, forced)
            new, en, dn = run(a, rel, False, forced)
            e = rel * (float(a.max()) - float(a.min()))
            best = None
            for p in peers.bounded(a.dtype, a.shape, e)[0]:
                if p.name in ("sz3", "sperr"):
                    pb = p.encode(a)
                    back = np.asarray(p.decode(pb), np.float64).reshape(a.shape)
                    if np.abs(back - a).max() <= e:
                        n = peers.nbytes(pb)
                        best = min(best or (n, p.name), (n, p.name))
            row = {"field": label, "shape": "x".join(map(str, a.shape)), "rel": rel,
                   "before": len(old), "after": len(new),
                   "gain": round(len(old) / len(new), 4),
                   "ratio_after": round(a.nbytes / len(new), 3),
                   "peer": best[1], "x_before": round(best[0] / len(old), 4),
                   "x_after": round(best[0] / len(new), 4),
                   "enc_cpu_before": round(eo, 2), "enc_cpu_after": round(en, 2),
                   "dec_cpu_before": round(do, 3), "dec_cpu_after": round(dn, 3)}  # fmt: skip
            print(row, flush=True)
            rows.append(row)
    with open(out, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)


if __name__ == "__main__":
    main(sys.argv[1])
