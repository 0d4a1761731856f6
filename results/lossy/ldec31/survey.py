"""Where a default-effort lossy decode spends its time (one worker, warm): per cell the
payload kinds, volpack's best decode against SZ3's (interleaved, CPU time, this process)
and bench_lossy_decode's stage timers.

    PYTHONPATH=<tree> python results/lossy/ldec31/survey.py [--rounds 7] [fields...] > out
"""

import argparse
import csv
import functools
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import cells  # noqa: E402
from bench_lossy_decode import (  # noqa: E402  (scripts/ is on the path through cells)
    STAGES,
    StageTimer,
    best_interleaved,
    payload_paths,
    profile_cell,
)  # fmt: skip

from volpack import api, peers  # noqa: E402


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--rounds", type=int, default=7)
    ap.add_argument("--profile", action="store_true")
    ap.add_argument("fields", nargs="*")
    args = ap.parse_args()
    timer = StageTimer() if args.profile else None
    sz3 = peers.sz3_encoder()
    out = csv.writer(sys.stdout, lineterminator="\n")
    out.writerow("field,rel,voxels,path,ratio,ms_volpack,ms_sz3,x_sz3,ns_voxel".split(",")
                 + ([f"ms_{s}" for s in STAGES] if timer else []))
    for name in args.fields or cells.TUNE + cells.HELDOUT:
        a = cells.field(name)
        for rel in cells.RELS:
            e = cells.bound(a, rel)
            b = cells.blob(name, rel, a)
            s = sz3(a, e)
            out = api.decompress_array(b)
            assert np.abs(out.astype(np.float64) - a).max() <= e
            calls = {"volpack": functools.partial(api.decompress_array, b),
                     "sz3": functools.partial(peers.sz3_decode, s, a.dtype, a.shape)}
            best = best_interleaved(calls, args.rounds)
            row = [name, f"{rel:g}", a.size, payload_paths(b), f"{a.nbytes / len(b):.2f}",
                   f"{1e3 * best['volpack']:.3f}", f"{1e3 * best['sz3']:.3f}",
                   f"{best['sz3'] / best['volpack']:.3f}", f"{1e9 * best['volpack'] / a.size:.2f}"]
            if timer:
                ms = profile_cell(timer, calls["volpack"], args.rounds)
                row += [f"{ms[s]:.3f}" for s in STAGES]
            out.writerow(row)
            sys.stdout.flush()


if __name__ == "__main__":
    main()
