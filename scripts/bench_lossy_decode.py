"""Lossy decoding speed against SPERR and SZ3, one core, with volpack's default coder.

For each float field and error bound (relative to the value range), volpack
(``api.compress_array(a, max_error=E)``, the defaults), SPERR (imagecodecs
``sperr_encode(a, mode="pwe", level=E)``) and SZ3 (pysz with its defaults, absolute bound
E) each encode the field once; then their decoders run in turns, ``--rounds`` times, the
order rotating every round, each decode timed in CPU seconds of this process
(``time.process_time``), and the best time of each kept. Every decoded array is checked
against the bound on every voxel (``bound_ok_*``; SPERR misses it by a rounding at some
tight bounds, which is recorded, not refused). The figure of merit is the ratio of decoding speeds
measured side by side, not the MB/s (the machine is shared).

Also recorded per cell: which payload volpack's brick(s) took (``formats/lossy-1.md``:
``cdf97`` the float wavelet path with its layout, ``interp`` the interpolation path,
``qvox`` the quantised voxels through the lossless wavelet codec, ``qvox(fast)``
through the fast codec (``--effort fast``), ``exact`` the lossless codec (``exact(fast)``
its lattices by the fast codec, ``--effort fast``), ``coef`` the
integer-coefficient path) and, with ``--profile``, where volpack's decode spends its
time: the stage functions of the decoders are wrapped with timers for a further
``--rounds`` decodes (entropy decoding, the fast codec's walk counted with it, inverse
transform, outliers, the interpolation walk, the fitted predictor, the rest: container,
checks, casts).

    python scripts/bench_lossy_decode.py --profile
    python scripts/bench_lossy_decode.py --label before   # e.g. with PYTHONPATH on main
    python scripts/bench_lossy_decode.py --encode 3 --coder arith2 --label arith2

Writes (appends) ``decode.csv`` and redraws ``decode_vs_peers.png`` in ``--out``
(default ``results/lossy/decode``).
"""

from __future__ import annotations

import argparse
import collections
import csv
import functools
import math
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import datasets  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
FIELDS = ["tgv_pressure", "climate_t", "tgv_u", "cryoem_emd3001", "xray_1jzv"]
RELS = (1e-2, 1e-3, 1e-4, 1e-5)
INT_RELS = (3e-4, 1e-3, 3e-3, 1e-2, 3e-2)  # scripts/bench_lossy.py's integer bounds
METHODS = ("volpack", "sperr", "sz3")
STAGES = ("entropy", "transform", "outliers", "interp", "fit", "rest")
CSV_FIELDS = [
    "label",
    "dataset",
    "shape",
    "rel_bound",
    "bound",
    "path",
    "ratio_volpack",
    "ratio_sperr",
    "ratio_sz3",
    "decode_MBps_volpack",
    "decode_MBps_sperr",
    "decode_MBps_sz3",
    "x_sperr",
    "x_sz3",
    *(f"bound_ok_{m}" for m in METHODS),
    *(f"ms_{s}" for s in STAGES),
    "coder",
    "effort",
    *(f"encode_MBps_{m}" for m in METHODS),
    "enc_x_sperr",
    "enc_x_sz3",
]


def codecs(coder: str | None = None, effort: str | None = None):
    """(encode(a, E) -> blob, decode(blob, a) -> array) per method; ``coder`` is
    volpack's entropy coder and ``effort`` its encoder's effort (their defaults when
    None)."""
    from volpack import api, peers

    sz3_encode = peers.sz3_encoder()
    return {
        "volpack": (
            lambda a, e: api.compress_array(
                a, max_error=float(e), **({"coder": coder} if coder else {}),
                **({"effort": effort} if effort else {}),
            ),
            lambda b, a: api.decompress_array(b),
        ),
        "sperr": (peers.sperr_bounded, lambda b, a: peers.sperr_decode(b).reshape(a.shape)),
        "sz3": (sz3_encode, lambda b, a: peers.sz3_decode(b, a.dtype, a.shape)),
    }


def nbytes(blob) -> int:
    return int(blob.nbytes) if isinstance(blob, np.ndarray) else len(blob)


def payload_paths(blob: bytes) -> str:
    """The payload kind of each brick of a bounded volpack stream (flag byte, inner
    header), joined by '+' when they differ."""
    from volpack.format.container import Reader

    kinds = []
    with Reader(blob) as r:
        for _t, _node, p in r:
            flags = p[0]
            if flags & 64:
                kind = f"interp(kind {p[8]})"
            elif flags & 16:
                lv, order = tuple(p[5:8]), p[8]
                kind = f"cdf97({'separable' if order == 3 else 'mallat'} {lv[0]},{lv[1]},{lv[2]})"
            elif flags & 4:
                kind = "coef"
            elif flags & 128:  # inner byte 6: lattices by the fast codec (effort 'fast')
                kind = "exact(fast)" if p[5] == 6 else "exact"
            else:  # inner byte 6: the fast codec's payload (effort 'fast')
                kind = "qvox(fast)" if p[5] == 6 else "qvox"
            if flags & 32:
                kind += "+outliers"
            if flags & 2:
                kind += "+corrections"
            kinds.append(kind)
    return "+".join(sorted(set(kinds)))


def best_interleaved(calls: dict, rounds: int) -> dict:
    """Best CPU time of each call over ``rounds`` rounds, the order rotating."""
    names = list(calls)
    best = {k: math.inf for k in names}
    for r in range(rounds):
        for k in names[r % len(names) :] + names[: r % len(names)]:
            t0 = time.process_time()
            calls[k]()
            best[k] = min(best[k], time.process_time() - t0)
    return best


class StageTimer:
    """Wraps the decoders' stage functions with CPU timers (only with --profile)."""

    def __init__(self):
        from volpack import entropy
        from volpack.volume_codec import (
            bin_field, bounded_cdf97, bounded_interp, fastpredict, predictfit,
        )  # fmt: skip
        from volpack.wavelet import cdf97, dwt3

        self.acc = collections.defaultdict(float)
        self.depth = 0
        for name in list(entropy.CODERS):  # each loaded (a module or a namespace) and wrapped
            coder = entropy.CODERS[name]
            coder.decode = self.timed(coder.decode, "entropy")
        self._wrap(cdf97, "inverse", "transform")
        self._wrap(dwt3, "inverse", "transform")
        self._wrap(bounded_cdf97, "apply_outliers", "outliers")
        self._wrap(bin_field, "add_decoded", "outliers")
        self._wrap(bounded_interp, "decode", "interp")
        self._wrap(predictfit, "decode", "fit")  # the fitted predictor on the quantised voxels
        # the fast codec's walk (prediction and static rANS: the quantised voxels of effort
        # 'fast') counted as entropy decoding
        self._wrap(fastpredict, "decode", "entropy")

    def _wrap(self, module, name, stage):
        module_fn = getattr(module, name)
        setattr(module, name, self.timed(module_fn, stage))

    def timed(self, fn, stage):
        @functools.wraps(fn)
        def run(*args, **kwargs):
            if self.depth:  # a stage inside another (outliers through a coder): count once
                return fn(*args, **kwargs)
            self.depth += 1
            t0 = time.process_time()
            try:
                return fn(*args, **kwargs)
            finally:
                self.acc[stage] += time.process_time() - t0
                self.depth -= 1

        return run


def profile_cell(timer: StageTimer, decode, rounds: int) -> dict:
    """Mean CPU milliseconds per stage over ``rounds`` decodes."""
    timer.acc.clear()
    t0 = time.process_time()
    for _ in range(rounds):
        decode()
    total = (time.process_time() - t0) / rounds
    ms = {s: 1e3 * timer.acc[s] / rounds for s in STAGES[:-1]}
    ms["rest"] = 1e3 * total - sum(ms.values())
    return ms


def run(args) -> list[dict]:
    methods = codecs(args.coder, args.effort)
    timer = StageTimer() if args.profile else None
    rows = []
    for name in args.datasets:
        a, _spacing, _desc = datasets.load(name)
        a = np.ascontiguousarray(a)
        vrange = float(a.max()) - float(a.min())
        mb = a.nbytes / 1e6
        for rel in args.rels if a.dtype.kind == "f" else args.int_rels:
            e = float(f"{vrange * rel:.4g}")
            # the peers get integers as float32, as in scripts/bench_lossy.py
            given = {m: a if m == "volpack" or a.dtype.kind == "f" else a.astype(np.float32)
                     for m in methods}  # fmt: skip
            blobs = {m: enc(given[m], e) for m, (enc, _dec) in methods.items()}
            calls = {m: functools.partial(methods[m][1], blobs[m], given[m]) for m in methods}
            held = {}
            for m, call in calls.items():  # the bound on every voxel, and a warm-up
                err = np.abs(np.asarray(call(), np.float64) - a).max()
                held[m] = bool(err <= e)
                if not held[m]:
                    print(f"WARNING: {name} {m} at E={e:g}: max error {err:.6g}", flush=True)
            best = best_interleaved(calls, args.rounds)
            enc = {}
            if args.encode:  # the encoders timed the same way (volpack's is slow: fewer rounds)
                encs = {m: functools.partial(methods[m][0], given[m], e) for m in methods}
                enc = best_interleaved(encs, args.encode)
            row = {
                "label": args.label,
                "dataset": name,
                "shape": "x".join(map(str, a.shape)),
                "rel_bound": f"{rel:g}",
                "bound": e,
                "path": payload_paths(blobs["volpack"]),
                **{f"ratio_{m}": round(a.nbytes / nbytes(blobs[m]), 4) for m in METHODS},
                **{f"decode_MBps_{m}": round(mb / best[m], 2) for m in METHODS},
                "x_sperr": round(best["sperr"] / best["volpack"], 3),
                "x_sz3": round(best["sz3"] / best["volpack"], 3),
                **{f"bound_ok_{m}": held[m] for m in METHODS},
                "coder": args.coder or "default",
                "effort": args.effort or "default",
            }
            if enc:
                row.update({f"encode_MBps_{m}": round(mb / enc[m], 2) for m in METHODS})
                row["enc_x_sperr"] = round(enc["sperr"] / enc["volpack"], 4)
                row["enc_x_sz3"] = round(enc["sz3"] / enc["volpack"], 4)
            if timer is not None:
                ms = profile_cell(timer, calls["volpack"], args.rounds)
                row.update({f"ms_{s}": round(v, 3) for s, v in ms.items()})
            rows.append(row)
            print(
                f"{name:15s} {rel:6g} {row['path']:40s} ratio {row['ratio_volpack']:7.2f}"
                f" | MB/s volpack {row['decode_MBps_volpack']:6.1f} sperr"
                f" {row['decode_MBps_sperr']:6.1f} sz3 {row['decode_MBps_sz3']:6.1f}"
                f" | x SPERR {row['x_sperr']:.2f} x SZ3 {row['x_sz3']:.2f}"
                + (
                    f" | encode MB/s {row['encode_MBps_volpack']:.2f}"
                    f" (x SZ3 {row['enc_x_sz3']:.3f})"
                    if enc
                    else ""
                )
                + (
                    " | ms " + " ".join(f"{s} {row[f'ms_{s}']:.2f}" for s in STAGES)
                    if timer is not None
                    else ""
                ),
                flush=True,
            )
    return rows


def write_csv(rows: list[dict], path: Path) -> None:
    """Append to ``path``, replacing earlier rows of the same label."""
    old = []
    if path.exists():
        with path.open() as f:
            old = [r for r in csv.DictReader(f) if r["label"] not in {x["label"] for x in rows}]
    with path.open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=CSV_FIELDS, extrasaction="ignore")
        w.writeheader()
        for r in old + rows:
            w.writerow({k: r.get(k, "") for k in CSV_FIELDS})


def write_chart(path_csv: Path, out: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    with path_csv.open() as f:
        rows = list(csv.DictReader(f))
    labels = list(dict.fromkeys(r["label"] for r in rows))
    cells = list(dict.fromkeys((r["dataset"], r["rel_bound"]) for r in rows))
    fig, axes = plt.subplots(2, 1, figsize=(min(18, max(8, 0.3 * len(cells) * len(labels))), 8))
    width = 0.8 / len(labels)
    for ax, key, goal, peer in ((axes[0], "x_sperr", 1.0, "SPERR"), (axes[1], "x_sz3", 0.5, "SZ3")):
        for k, label in enumerate(labels):
            by = {(r["dataset"], r["rel_bound"]): float(r[key]) for r in rows if r["label"] == label}
            xs = [i + (k - (len(labels) - 1) / 2) * width for i in range(len(cells))]
            ax.bar(xs, [by.get(c, 0.0) for c in cells], width, label=label)
        ax.axhline(goal, color="k", lw=1, ls="--")
        ax.set_ylabel(f"volpack decode speed / {peer}'s")
        ax.set_xticks(range(len(cells)))
        ax.set_xticklabels([f"{d}\n{b}" for d, b in cells], fontsize=7, rotation=90)
        ax.set_title(f"goal: >= {goal:g}x {peer} (dashed)", fontsize=9)
        ax.legend(fontsize=8)
    fig.suptitle("Lossy decode speed, one core, same data, interleaved best-of (CPU time)")
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    plt.close(fig)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--datasets", default=",".join(FIELDS))
    ap.add_argument("--rels", default=",".join(f"{r:g}" for r in RELS))
    ap.add_argument(
        "--int-rels", default=",".join(f"{r:g}" for r in INT_RELS),
        help="the bounds of integer volumes (relative to their range; 1e-4 of a 12-bit "
        "range is under 1, coded losslessly)",
    )  # fmt: skip
    ap.add_argument("--rounds", type=int, default=7)
    ap.add_argument("--label", default="after")
    ap.add_argument("--profile", action="store_true", help="time volpack's decode stages")
    ap.add_argument("--coder", default=None, help="volpack's entropy coder (default: its own)")
    ap.add_argument("--effort", default=None, help="volpack's encoder effort (default: its own)")
    ap.add_argument(
        "--encode", type=int, default=0, metavar="N", help="also time the encoders, best of N"
    )
    ap.add_argument("--out", type=Path, default=ROOT / "results" / "lossy" / "decode")
    ap.add_argument(
        "--min-saving", type=float, default=None,
        help="volpack's encoder: the saving a slower-decoding coding must make (default: its own)",
    )  # fmt: skip
    args = ap.parse_args(argv)
    if args.min_saving is not None:
        from volpack.volume_codec import lossy

        lossy.SLOW_MIN_SAVING = args.min_saving
    args.datasets = [d for d in args.datasets.split(",") if d]
    args.rels = [float(r) for r in args.rels.split(",") if r]
    args.int_rels = [float(r) for r in args.int_rels.split(",") if r]
    import volpack

    print(f"volpack from {Path(volpack.__file__).parent}", flush=True)
    rows = run(args)
    args.out.mkdir(parents=True, exist_ok=True)
    write_csv(rows, args.out / "decode.csv")
    write_chart(args.out / "decode.csv", args.out / "decode_vs_peers.png")


if __name__ == "__main__":
    main()
