"""Where volpack's lossy decode (and encode) spends its CPU time, stage by stage.

For each float field and bound (relative to the value range), the field is encoded once
with ``api.compress_array(a, max_error=E)`` and decoded once to warm numba's cache; then
``--rounds`` decodes run under ``cProfile`` and each function's own time (``tottime``)
is put into a stage by the function's module and name (:data:`STAGES`); ``python``
(the container, headers, checks and numpy glue) is the best un-profiled CPU time of a
decode less the other stages. Stage times are CPU milliseconds per decode.
``--encode`` profiles one encode the same way, by the bounded encoder's candidate paths.

    python scripts/profile_lossy_stages.py --datasets cam_u,tgv_u,climate_t --out results/x
"""

from __future__ import annotations

import argparse
import cProfile
import csv
import math
import pstats
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import datasets  # noqa: E402

# (module path fragment, function name or "*") -> stage; the first match wins.
STAGES = [
    (("entropy/arith.py", "decode_kernel"), "entropy"),
    (("entropy/arith2.py", "_decode_kernel"), "entropy"),
    (("entropy/static.py", "*"), "entropy"),
    (("entropy/fixed.py", "*"), "entropy"),
    (("entropy/rans.py", "*"), "entropy"),
    (("predictfit.py", "_decode_kernel"), "entropy+predict"),
    (("predict.py", "_decode_kernel"), "entropy+predict"),
    (("bounded_interp.py", "_decode_walk"), "entropy+predict"),
    (("bounded_interp.py", "_decode_walk_adaptive"), "entropy+predict"),
    (("wavelet/cdf97.py", "_inverse_kernel"), "inverse wavelet"),
    (("wavelet/dwt3.py", "dwt3_kernel"), "inverse wavelet"),
    (("wavelet/lifting.py", "*"), "inverse wavelet"),
    (("floatcast.py", "_scale_over"), "dequantise"),
    (("bounded_cdf97.py", "decode"), "dequantise"),  # main: q * step in its own time
    (("bin_field.py", "_decode_kernel"), "outlier bins"),
    (("bounded_cdf97.py", "apply_outliers"), "outlier bins"),
    (("bounded_cdf97.py", "add_bins"), "outlier bins"),
    (("lossy.py", "apply_corrections"), "exact corrections"),
    (("labels.py", "*"), "mask/fill"),
    (("bgmask.py", "*"), "mask/fill"),
    (("floatcast.py", "*"), "cast/dequantise"),
    (("dwt3.py", "_narrow_kernel"), "cast/dequantise"),
    (("lossy.py", "_reconstruct"), "cast/dequantise"),
    (("~", "<method 'astype' of 'numpy.ndarray' objects>"), "cast/dequantise"),
    (("~", "<method 'decompress' of 'zstandard.backend_c.ZstdDecompressionObj' objects>"), "zstd"),
]
ENCODE_STAGES = [
    (("predictfit.py", "*"), "fitted predictor (qvox)"),
    (("predict.py", "*"), "predictor v1 (qvox)"),
    (("lossless.py", "*"), "fitted predictor (qvox)"),
    (("entropy/arith.py", "*"), "coefficients: arith"),
    (("entropy/arith2.py", "*"), "coefficients: arith2"),
    (("bounded_interp.py", "*"), "interpolation path"),
    (("wavelet/cdf97.py", "*"), "cdf97 transforms"),
    (("wavelet/packet.py", "*"), "cdf97 transforms"),
    (("bounded_cdf97.py", "*"), "cdf97 search"),
    (("bin_field.py", "*"), "outlier bins"),
    (("wavelet/dwt3.py", "*"), "integer wavelet"),
    (("wavelet/lifting.py", "*"), "integer wavelet"),
    (("_linalg.py", "*"), "fitted predictor (qvox)"),
]


def stage_of(key, table) -> str:
    path, _line, func = key
    for (frag, name), stage in table:
        if (frag == "~" and path == "~" and func == name) or (
            frag != "~" and path.endswith(frag) and name in ("*", func)
        ):
            return stage
    return "python"


def profile(call, rounds: int, table) -> tuple[dict, float]:
    """CPU seconds per call by stage, and the best un-profiled CPU time of a call. The
    profiler's own cost lands on the many small Python calls, so ``python`` is the
    un-profiled time less the other stages (whose kernels are single long calls)."""
    total = math.inf
    for _ in range(rounds):
        t0 = time.process_time()
        call()
        total = min(total, time.process_time() - t0)
    pr = cProfile.Profile(time.process_time)  # CPU time, as the total
    pr.enable()
    for _ in range(rounds):
        call()
    pr.disable()
    acc: dict[str, float] = {}
    for key, (_cc, _nc, tt, _ct, _callers) in pstats.Stats(pr).stats.items():
        s = stage_of(key, table)
        if s != "python":
            acc[s] = acc.get(s, 0.0) + tt / rounds
    acc["python"] = max(0.0, total - sum(acc.values()))
    return acc, total


def main(argv=None) -> None:
    from volpack import api

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--datasets", default="cam_u,tgv_u,climate_t")
    ap.add_argument("--rels", default="1e-3,1e-4")
    ap.add_argument("--rounds", type=int, default=20)
    ap.add_argument("--encode", action="store_true", help="profile one encode too")
    ap.add_argument("--label", default="")
    ap.add_argument("--effort", default="default", help="volpack's encoder effort")
    ap.add_argument("--out", type=Path, required=True)
    args = ap.parse_args(argv)
    rows = []
    for name in [d for d in args.datasets.split(",") if d]:
        a = np.ascontiguousarray(datasets.load(name)[0])
        vrange = float(a.max()) - float(a.min())
        for rel in [float(r) for r in args.rels.split(",") if r]:
            e = float(f"{vrange * rel:.4g}")
            blob = api.compress_array(a, max_error=e, effort=args.effort)
            api.decompress_array(blob)  # warm: kernels loaded from numba's cache
            runs = [("decode", lambda: api.decompress_array(blob), args.rounds, STAGES)]
            if args.encode:
                enc = lambda: api.compress_array(a, max_error=e, effort=args.effort)  # noqa: E731
                runs.append(("encode", enc, 1, ENCODE_STAGES))
            for what, call, rounds, table in runs:
                acc, total = profile(call, rounds, table)
                for s, t in sorted(acc.items(), key=lambda kv: -kv[1]):
                    rows.append({
                        "label": args.label, "dataset": name, "rel_bound": f"{rel:g}",
                        "what": what, "stage": s, "ms": round(1e3 * t, 3),
                        "share": round(t / total, 4) if total else 0.0,
                        "total_ms": round(1e3 * total, 3), "MBps": round(a.nbytes / 1e6 / total, 2),
                    })  # fmt: skip
                top = ", ".join(
                    f"{r['stage']} {r['ms']:.2f}" for r in rows if r["dataset"] == name
                    and r["rel_bound"] == f"{rel:g}" and r["what"] == what
                )
                print(f"{name:12s} {rel:6g} {what} {1e3 * total:8.2f} ms: {top}", flush=True)
    args.out.mkdir(parents=True, exist_ok=True)
    path = args.out / "stages.csv"
    old = []
    if path.exists():
        with path.open() as f:
            old = [r for r in csv.DictReader(f) if r["label"] != args.label]
    with path.open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(old + rows)


if __name__ == "__main__":
    main()
