"""The fast codec's decode speed per core and ratio against JPEG-LS, zstd and JPEG-XL,
in one process, interleaved, best of ``--repeat``.

For each volume, the codings (made once):

* ``fast``: ``api.compress_array(codec="fast")`` (64^3 bricks; zstd bricks, mode 3, on);
* ``fast-nozstd``: the same with ``zstd=False``, the streams of before mode 3 (the same
  decoder reads both, so this is the before of a before/after in one sitting);
* ``jpegls``: CharLS through imagecodecs, one frame per z slice (signed volumes shifted
  to unsigned, and the decoded slices stacked back, outside the timing);
* ``zstd19``: zstandard level 19, one frame of the whole volume's bytes;
* ``jpegxl``: libjxl through imagecodecs, lossless, one frame per z slice at effort
  ``--jxl-effort`` (skipped with ``--no-jxl``).

Then ``--repeat`` rounds, each decoding every coding once in turn (``fast`` by
``api.decompress_array(workers=1)``, the whole reader); CPU seconds
(``time.process_time``), the best per coding. MB = 1e6 bytes of raw voxels. Every
decode is checked equal to the volume once.

    python scripts/bench_fast_peers.py --all --repeat 7
    python scripts/bench_fast_peers.py liver_labels ct_head --no-jxl

Outputs in ``--out`` (default ``results/lossless``): ``fast_peers.csv`` and
``fast_peers.md`` (rows replaced per volume and ``--label``).
"""

from __future__ import annotations

import argparse
import csv
import os
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

CODINGS = ("fast", "fast-nozstd", "jpegls", "zstd19", "jpegxl")
FIELDS = ["label", "dataset", "shape", "dtype"] + [
    f"{c}_{k}" for c in CODINGS for k in ("ratio", "mb_s")
] + ["fast_vs_jpegls_speed", "fast_vs_jpegls_ratio", "zstd_bricks", "bricks", "load"]


def codings(a: np.ndarray, jxl_effort: int | None) -> dict:
    """``{name: (nbytes, decode(), volume(decoded))}``: ``decode`` is what is timed (for
    the per-slice peers the list of decoded slices, as ``bench_decode.py`` times them),
    ``volume`` makes of its result the array checked against ``a``."""
    import imagecodecs as ic
    import zstandard

    from volpack import api
    from volpack.format.container import Reader
    from volpack.volume_codec.fast import describe

    def same(decoded):
        return decoded

    out = {}
    for name, opts in (("fast", {}), ("fast-nozstd", {"zstd": False})):
        blob = api.compress_array(a, codec="fast", **opts)
        out[name] = (len(blob), lambda b=blob: api.decompress_array(b, workers=1), same)
        if name == "fast":
            with Reader(blob) as r:
                kinds = [describe(r.read(e.t, e.node)) for e in r.entries]
            zb, nb = kinds.count("zstd"), len(kinds)
    shift = 1 << (8 * a.itemsize - 1) if a.dtype.kind == "i" else 0
    u = (a.astype(np.int64) + shift).astype(f"u{a.itemsize}")

    def stacked(decoded):  # outside the timing: unsigned slices back to the volume
        return (np.stack(decoded).astype(np.int64) - shift).astype(a.dtype)

    enc = [ic.jpegls_encode(s) for s in u]
    out["jpegls"] = (
        sum(map(len, enc)), lambda e=enc: [ic.jpegls_decode(f) for f in e], stacked
    )
    z = zstandard.ZstdCompressor(level=19).compress(np.ascontiguousarray(a).tobytes())
    out["zstd19"] = (
        len(z),
        lambda: np.frombuffer(
            zstandard.ZstdDecompressor().decompress(z, max_output_size=a.nbytes), a.dtype
        ).reshape(a.shape),
        same,
    )
    if jxl_effort is not None:
        enc = [ic.jpegxl_encode(s, lossless=True, effort=jxl_effort) for s in u]
        out["jpegxl"] = (
            sum(map(len, enc)), lambda e=enc: [ic.jpegxl_decode(f) for f in e], stacked
        )
    return out, zb, nb


def measure(name: str, a: np.ndarray, repeat: int, label: str, jxl_effort: int | None) -> dict:
    cods, zb, nb = codings(a, jxl_effort)
    for c, (_, dec, volume) in cods.items():
        if not np.array_equal(volume(dec()), a):
            raise AssertionError(f"{name}: {c} did not round-trip")
    best = {c: float("inf") for c in cods}
    for _ in range(repeat):
        for c, (_, dec, _) in cods.items():
            t = time.process_time()
            dec()
            best[c] = min(best[c], time.process_time() - t)
    mb = a.nbytes / 1e6
    row = {
        "label": label,
        "dataset": name,
        "shape": "x".join(map(str, a.shape)),
        "dtype": str(a.dtype),
        "zstd_bricks": zb,
        "bricks": nb,
        "load": f"{os.getloadavg()[0]:.1f}",
    }
    for c in CODINGS:
        if c in cods:
            row[f"{c}_ratio"] = round(a.nbytes / cods[c][0], 3)
            row[f"{c}_mb_s"] = round(mb / max(best[c], 1e-9), 1)
        else:
            row[f"{c}_ratio"] = row[f"{c}_mb_s"] = ""
    row["fast_vs_jpegls_speed"] = round(best["jpegls"] / best["fast"], 3)
    row["fast_vs_jpegls_ratio"] = round(row["fast_ratio"] / row["jpegls_ratio"], 3)
    return row


def write(rows: list[dict], out: Path) -> None:
    out.mkdir(parents=True, exist_ok=True)
    path = out / "fast_peers.csv"
    old = []
    if path.exists():
        with path.open() as f:
            old = list(csv.DictReader(f))
    keys = {(r["label"], r["dataset"]) for r in rows}
    allrows = [r for r in old if (r["label"], r["dataset"]) not in keys] + rows
    with path.open("w", newline="") as f:
        w = csv.DictWriter(f, FIELDS)
        w.writeheader()
        w.writerows(allrows)
    lines = [
        "# The fast codec against JPEG-LS, zstd and JPEG-XL: ratio and decode MB/s per core",
        "",
        "`python scripts/bench_fast_peers.py ...` (see the script): CPU seconds, best of the"
        " rounds, every coding decoded once a round in one process. `fast-nozstd` = the fast"
        " codec without its zstd bricks (the streams of before them). `vs JPEG-LS` = fast"
        " over JPEG-LS, speed and ratio.",
        "",
        "| run | volume | shape dtype | fast ratio | fast MB/s | fast-nozstd ratio"
        " | fast-nozstd MB/s | JPEG-LS ratio | JPEG-LS MB/s | zstd-19 ratio | zstd-19 MB/s"
        " | JPEG-XL ratio | JPEG-XL MB/s | vs JPEG-LS speed | vs JPEG-LS ratio"
        " | zstd bricks | load |",
        "|---|---|---|" + "---:|" * 14,
    ]
    for r in allrows:
        cells = [f"{r[f'{c}_ratio']} | {r[f'{c}_mb_s']}" for c in CODINGS]
        lines.append(
            f"| {r['label']} | {r['dataset']} | {r['shape']} {r['dtype']} | "
            + " | ".join(cells)
            + f" | {r['fast_vs_jpegls_speed']} | {r['fast_vs_jpegls_ratio']}"
            f" | {r['zstd_bricks']}/{r['bricks']} | {r['load']} |"
        )
    (out / "fast_peers.md").write_text("\n".join(lines) + "\n")


def main() -> None:
    import datasets

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("names", nargs="*")
    ap.add_argument("--all", action="store_true", help="every integer volume in the cache")
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--jxl-effort", type=int, default=7)
    ap.add_argument("--no-jxl", action="store_true")
    ap.add_argument("--label", default="run")
    ap.add_argument("--out", type=Path, default=HERE.parent / "results" / "lossless")
    args = ap.parse_args()
    names = datasets.names() if args.all else args.names
    rows = []
    for name in names:
        a, _, _ = datasets.load(name)
        row = measure(name, a, args.repeat, args.label, None if args.no_jxl else args.jxl_effort)
        print(
            f"{name}: fast {row['fast_ratio']} @ {row['fast_mb_s']} MB/s, before "
            f"{row['fast-nozstd_ratio']} @ {row['fast-nozstd_mb_s']}, JPEG-LS "
            f"{row['jpegls_ratio']} @ {row['jpegls_mb_s']}, zstd-19 {row['zstd19_ratio']} @ "
            f"{row['zstd19_mb_s']}, JPEG-XL {row['jpegxl_ratio']} @ {row['jpegxl_mb_s']}",
            flush=True,
        )
        rows.append(row)
        write(rows, args.out)


if __name__ == "__main__":
    main()
