"""Every float tool's payload size and CPU time on every 128^3 brick of the given
volumes (the candidates LosslessCodec.encode weighs at the default version), to see
which tools win, which cannot, and what each costs.

    PYTHONPATH=. python results/lossless/flen31/variants.py OUT.csv NAME_OR_NPY...
"""

from __future__ import annotations

import csv
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from tools_profile import volume  # noqa: E402

from volpack.volume_codec import (  # noqa: E402
    floatfit,
    floatmix,
    lossless,  # noqa: E402
)
from volpack.volume_codec import floatpredict as fp
from volpack.volume_codec.codec import ZstdCodec  # noqa: E402

B = 128


def timed(fn, *a, **k):
    t = time.process_time()
    out = fn(*a, **k)
    return out, time.process_time() - t


def bricks(a):
    for z in range(0, a.shape[0], B):
        for y in range(0, a.shape[1], B):
            for x in range(0, a.shape[2], B):
                yield (z, y, x), np.ascontiguousarray(a[z : z + B, y : y + B, x : x + B])


def main() -> None:
    out, specs = sys.argv[1], sys.argv[2:]
    codec = lossless.LosslessCodec()
    codec.encode(volume("ct_skull_float")[:40, :40, :40])  # compile
    rows = []
    for spec in specs:
        a = volume(spec)
        for pos, b in bricks(a):
            r = {"volume": spec, "brick": "_".join(map(str, pos)), "voxels": b.size}
            full, r["t_total"] = timed(codec.encode, b)
            r["best"], r["tool"] = len(full), lossless.describe(full)
            z9, r["t_zstd9"] = timed(ZstdCodec(level=9).encode, b)
            z19, r["t_zstd19"] = timed(ZstdCodec(level=19).encode, b)
            r["zstd9"], r["zstd19"] = len(z9), len(z19)
            pred, r["t_predict"] = timed(lossless._encode_predict, b, 8, len(z9))
            r["predict"] = min(map(len, pred))
            for p in fp.usable(b.dtype):
                if b.shape[0] > 1 or p in (fp.LORENZO2, fp.LORENZO2F):
                    s, r[f"t_lor{p}"] = timed(fp.encode_lorenzo, b, p)
                    r[f"lor{p}"] = len(s)
            face = min((p for p in range(4) if f"lor{p}" in r), key=lambda p: r[f"lor{p}"])
            lat, r["t_latfind"] = timed(fp.find_lattices, b)
            r["n_lat"] = len(lat)
            t = time.process_time()
            r["lattice"] = min(
                (len(codec.encode(k)) + len(codec.encode(g)) for _, k, g in lat), default=""
            )
            r["t_latcode"] = time.process_time() - t
            w, r["t_fit_ls"] = timed(floatfit.fit, b)
            if w is not None:
                s, r["t_fit"] = timed(floatfit.encode, b, face, w)
                r["fit"] = len(s)
                s, r["t_fitface"] = timed(floatfit.encode, b, face)
                r["fitface"] = len(s)
            (offs, fill), r["t_blendprep"] = timed(
                lambda b=b: (floatmix.copy_offsets(b), floatmix.fill_value(b))
            )
            s, r["t_blend"] = timed(floatmix.encode, b, offsets=offs, fill=fill)
            r["blend"] = len(s)
            rows.append(r)
            print(r, flush=True)
    keys = []
    for r in rows:
        keys += [k for k in r if k not in keys]
    with open(out, "w", newline="") as f:
        w = csv.DictWriter(f, keys)
        w.writeheader()
        w.writerows(rows)


if __name__ == "__main__":
    main()
