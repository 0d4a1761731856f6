"""Encode time and bytes of the default-effort lossy encoder, one worker, per cell.

    PYTHONPATH=. python results/lossy/enc29/bench.py OUT.csv [--fields tune|heldout|NAME,..]
        [--paths PATHS.csv] [--effort default|max] [--bounds 1e-2,1e-3] [--exhaustive]

Cells: each field at max_error = rel * value range. ``--paths`` also records, per brick,
each candidate path's bytes and CPU seconds (wrapping BoundedCodec's methods).
CPU time: time.process_time of this process (one worker); a warm-up encode first."""

import argparse
import csv
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "scripts"))

import volpack  # noqa: E402
from volpack import api  # noqa: E402
from volpack.volume_codec import lossy  # noqa: E402

TUNE = [
    "zmap_neurovault", "climate_t", "cam_u", "hgt_500", "tgv_vorticity", "mri_piesno_noise",
    "mri_dipy_float", "climate_rh", "cam_t", "tas_monthly", "sea_ice", "tgv_pressure", "tgv_u",
]  # fmt: skip
HELDOUT_DIR = Path("/tmp/enc29_heldout")
HELDOUT = ["turb", "orbital", "mixing", "lognormal", "precip", "shock", "smooth256"]

PATHS = []  # rows (cell, path, bytes, seconds)
_cell = [""]


def _wrap(name, size_of):
    orig = getattr(lossy.BoundedCodec, name)

    def wrapped(self, *a, **k):
        t = time.process_time()
        out = orig(self, *a, **k)
        PATHS.append((_cell[0], name, size_of(out), time.process_time() - t))
        return out

    setattr(lossy.BoundedCodec, name, wrapped)


def instrument():
    def sizes(lst):
        return ";".join(str(len(b)) for _, b in lst) if lst else ""

    _wrap("_code_quantised", sizes)
    _wrap("_coef_candidate", lambda m: str(len(m[0])))
    _wrap("_cdf97_candidates", lambda ms: ";".join(str(len(m[0])) for m in ms))
    _wrap("_interp_candidate", lambda tm: str(len(tm[1][0])))
    _wrap("_longfit", sizes)
    _wrap("_exact_candidate", lambda m: str(len(m[0])))
    _wrap("_encode_masked", lambda m: str(len(m[0])))


def load_field(name):
    if name in HELDOUT:
        return np.load(HELDOUT_DIR / f"{name}.npy")
    from datasets import load

    return load(name)[0]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("out")
    ap.add_argument("--fields", default="tune")
    ap.add_argument("--bounds", default="1e-2,1e-3,1e-4,1e-5")
    ap.add_argument("--effort", default="default")
    ap.add_argument("--paths")
    ap.add_argument("--exhaustive", action="store_true", help="lossy.PRUNE = False")
    a = ap.parse_args()
    lossy.PRUNE = not a.exhaustive
    print(volpack.__file__, file=sys.stderr)
    names = {"tune": TUNE, "heldout": HELDOUT}.get(a.fields) or a.fields.split(",")
    if a.paths:
        instrument()
    warm = np.random.default_rng(0).standard_normal((24, 24, 24)).astype(np.float32)
    coarse = np.round(np.cumsum(warm, axis=2) * 4) / 4  # the exact path's kernels too
    for rel in (1e-2, 1e-3, 1e-5):  # every path's kernels compiled before the timing
        api.compress_array(np.cumsum(warm, axis=2), max_error=rel * 40, effort=a.effort)
        api.compress_array(coarse, max_error=rel * 4, effort=a.effort)
    rows = []
    for name in names:
        x = load_field(name)
        lo, hi = float(np.nanmin(x)), float(np.nanmax(x))
        for rel in (float(r) for r in a.bounds.split(",")):
            _cell[0] = f"{name}@{rel:g}"
            t = time.process_time()
            blob = api.compress_array(x, max_error=rel * (hi - lo), effort=a.effort, workers=1)
            cpu = time.process_time() - t
            y = api.decompress_array(blob)
            err = float(np.nanmax(np.abs(y.astype(np.float64) - x)))
            ok = err <= rel * (hi - lo)
            rows.append((name, rel, len(blob), round(cpu, 3), ok))
            print(name, rel, len(blob), f"{cpu:.2f}s", ok, file=sys.stderr, flush=True)
    with open(a.out, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["field", "rel", "bytes", "cpu_s", "bound_ok"])
        w.writerows(rows)
    if a.paths:
        with open(a.paths, "w", newline="") as f:
            w = csv.writer(f)
            w.writerow(["cell", "path", "bytes", "cpu_s"])
            w.writerows((c, p, b, round(s, 4)) for c, p, b, s in PATHS)


if __name__ == "__main__":
    main()
