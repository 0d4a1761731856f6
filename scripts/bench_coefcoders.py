"""Coefficient coders alone: decode speed and coded size of ``arith2`` and ``static``
against ``arith``.

Each volume is compressed once with the ``arith`` coder (lossless wavelet codec, or the
error-bounded lossy path at ``--rel-error`` of the value range for ``lossy:NAME``) while
every coefficient array the codec hands the coder is recorded; the coders then code and
decode exactly those arrays in this process, alternating, best of ``--repeat``. MB/s is
the volume's raw bytes over the decode time of all its arrays (on lossy fields the
encoder's candidates are coded too, so compare the two coders' figures, not with other
benchmarks). Every decode is checked against its array.

    python scripts/bench_coefcoders.py ct_head mri_ch2bet_07mm lossy:tgv_pressure

Writes ``coefcoders.csv`` and ``coefcoders.png`` (speed-up against size change) in
``--out`` (default ``results/coefcoders``).
"""

from __future__ import annotations

import argparse
import csv
import sys
import time
from pathlib import Path
from types import SimpleNamespace

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(Path(__file__).resolve().parent))

FIELDS = ["volume", "mode", "arrays", "coefficients", "raw_bytes", "coder", "bytes",
          "decode_s", "decode_mb_s"]  # fmt: skip


def record(a: np.ndarray, options: dict) -> list:
    """The (coefficients, scan) pairs the ``arith`` coder is handed while ``a`` is
    compressed with ``options``."""
    from volpack import api
    from volpack.entropy import CODERS

    jobs = []
    real = CODERS["arith"]

    def encode(coeffs, scan):
        jobs.append((coeffs.copy(), scan))
        return real.encode(coeffs, scan)

    CODERS["arith"] = SimpleNamespace(encode=encode, decode=real.decode)
    try:
        api.compress_array(a, **options)
    finally:
        CODERS["arith"] = real
    return jobs


def decode_time(coder, blobs, jobs) -> float:
    outs = [np.empty_like(c) for c, _ in jobs]
    t = time.process_time()
    for blob, (_, scan), out in zip(blobs, jobs, outs):
        coder.decode(blob, scan, out)
    dt = time.process_time() - t
    for (c, _), out in zip(jobs, outs):
        if not np.array_equal(c, out):
            raise AssertionError("a coder did not round-trip its coefficients")
    return dt


def run(name: str, rel_error: float, repeat: int) -> list[dict]:
    from datasets import load

    from volpack.entropy import CODERS

    lossy = name.startswith("lossy:")
    a = load(name.split(":", 1)[1] if lossy else name)[0]
    if lossy:
        span = float(np.nanmax(a) - np.nanmin(a))
        options = {"max_error": rel_error * span, "coder": "arith"}  # (the default: auto)
        mode = f"lossy {rel_error:g} of range"
    else:
        options, mode = {"codec": "wavelet", "coder": "arith"}, "lossless wavelet"
    jobs = record(a, options)
    coders = ("arith", "arith2", "static")
    blobs = {c: [CODERS[c].encode(x, s) for x, s in jobs] for c in coders}
    best = dict.fromkeys(coders, float("inf"))
    for _ in range(repeat):  # alternate, so both see the same machine load
        for c in coders:
            best[c] = min(best[c], decode_time(CODERS[c], blobs[c], jobs))
    rows = []
    for c in coders:
        rows.append({
            "volume": name, "mode": mode, "arrays": len(jobs),
            "coefficients": sum(x.size for x, _ in jobs), "raw_bytes": a.nbytes, "coder": c,
            "bytes": sum(map(len, blobs[c])), "decode_s": round(best[c], 4),
            "decode_mb_s": round(a.nbytes / best[c] / 1e6, 2),
        })  # fmt: skip
    one = rows[0]
    print(
        f"{name:20s} {mode:22s} arith {one['bytes']:9d} B {one['decode_mb_s']:6.1f} MB/s"
        + "".join(
            f" | {r['coder']} {r['bytes']:9d} B ({100 * (r['bytes'] / one['bytes'] - 1):+.2f} %)"
            f" {r['decode_mb_s']:6.1f} MB/s, {one['decode_s'] / r['decode_s']:.2f}x"
            for r in rows[1:]
        ),
        flush=True,
    )
    return rows


def plot(rows: list[dict], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 4))
    by = {}
    for r in rows:
        by.setdefault(r["volume"], {})[r["coder"]] = r
    for name, pair in by.items():
        one, two = pair["arith"], pair["arith2"]
        x = 100 * (two["bytes"] / one["bytes"] - 1)
        y = one["decode_s"] / two["decode_s"]
        ax.scatter([x], [y])
        ax.annotate(name, (x, y), fontsize=7, xytext=(3, 3), textcoords="offset points")
    ax.axhline(1.8, color="grey", lw=0.8, ls="--")
    ax.axvline(1.0, color="grey", lw=0.8, ls="--")
    ax.set_xlabel("arith2 size against arith (%)")
    ax.set_ylabel("arith2 decode speed-up over arith (x)")
    ax.set_title("coefficient coders alone, one core")
    fig.tight_layout()
    fig.savefig(path, dpi=120)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("volumes", nargs="*", default=["ct_head"], help="names, lossy:NAME for floats")
    p.add_argument("--rel-error", type=float, default=1e-3, help="lossy bound / value range")
    p.add_argument("--repeat", type=int, default=7)
    p.add_argument("--out", type=Path, default=ROOT / "results" / "coefcoders")
    args = p.parse_args(argv)
    rows = []
    for name in args.volumes:
        rows += run(name, args.rel_error, args.repeat)
    args.out.mkdir(parents=True, exist_ok=True)
    with open(args.out / "coefcoders.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=FIELDS)
        w.writeheader()
        w.writerows(rows)
    plot(rows, args.out / "coefcoders.png")
    print(f"wrote {args.out}/coefcoders.csv and coefcoders.png")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
