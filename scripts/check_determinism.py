"""The same input and options give the same bytes on any machine: compress a set of
corpus fields in fresh processes that differ in OpenBLAS's thread count
(``OPENBLAS_NUM_THREADS``, as machines with other core counts would run) and in volpack's
worker count, and compare the files' hashes.

    python scripts/check_determinism.py cam_u tgv_u mri_dipy_s0 --out results/determinism
"""

from __future__ import annotations

import argparse
import csv
import hashlib
import itertools
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

MODES = {
    "default": {},
    "max": {"effort": "max"},
    "rel1e-3": {"rel_error": 1e-3},
    "rel1e-4-max": {"rel_error": 1e-4, "effort": "max"},
    "psnr60": {"psnr": 60.0},
}

CHILD = r"""
import hashlib, json, sys
sys.path.insert(0, {scripts!r})
import datasets
import volpack
from volpack import api
print(volpack.__file__, file=sys.stderr)
a, _, _ = datasets.load({name!r})
out = {{}}
for mode, opts in json.loads({modes!r}).items():
    if a.dtype.kind != "f" and ("psnr" in opts):
        continue
    b = api.compress_array(a, workers={workers}, **opts)
    out[mode] = [len(b), hashlib.sha256(b).hexdigest()[:16]]
print(json.dumps(out))
"""


def run(name: str, blas: int, workers: int) -> dict:
    env = {**os.environ, "OPENBLAS_NUM_THREADS": str(blas), "OMP_NUM_THREADS": str(blas)}
    code = CHILD.format(
        scripts=str(Path(__file__).resolve().parent), name=name, modes=json.dumps(MODES),
        workers=workers,
    )
    # run from a scratch folder: a '-c' child puts its working folder first on sys.path,
    # which would shadow a PYTHONPATH naming another tree
    r = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                       check=True, cwd=tempfile.gettempdir())  # fmt: skip
    return json.loads(r.stdout.strip().splitlines()[-1])


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("datasets", nargs="+")
    ap.add_argument("--blas", type=int, nargs="+", default=[1, 2, 4])
    ap.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--out", type=Path, default=Path("results/determinism"))
    args = ap.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    rows, differ = [], 0
    for name in args.datasets:
        runs = {(b, w): run(name, b, w) for b, w in itertools.product(args.blas, args.workers)}
        first = next(iter(runs.values()))
        for mode in first:
            seen = {k: v[mode] for k, v in runs.items()}
            same = len({tuple(v) for v in seen.values()}) == 1
            differ += not same
            sizes = sorted({v[0] for v in seen.values()})
            rows.append({"dataset": name, "mode": mode, "same": same, "bytes": " ".join(map(str, sizes)),
                         "runs": len(seen)})  # fmt: skip
            print(f"{name:16s} {mode:12s} {'same' if same else 'DIFFERS'} {sizes}", flush=True)
    path = args.out / "determinism.csv"
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    print(f"{differ} of {len(rows)} cases differ; wrote {path}")
    return 1 if differ else 0


if __name__ == "__main__":
    raise SystemExit(main())
