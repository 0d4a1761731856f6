"""Two runs of ``scripts/bench_lossy_decode.py`` side by side, cell by cell.

Reads ``decode.csv`` and prints, per field and bound, volpack's payload, ratio (with
SZ3's), decoding speed (MB/s, x SZ3, x SPERR, each against the peers of its own run) and
whether the bound held on every voxel, for the runs labelled ``before`` and ``after``
(or the two labels given); then how many cells reach the issue's goals (>= 0.5x SZ3's
decode speed, >= SPERR's) and the geometric means.

    python scripts/lossy_before_after.py results/lossy/fast23/decode.csv [before after]
"""

from __future__ import annotations

import csv
import math
import sys


def main(path: str, before: str = "before", after: str = "after") -> None:
    with open(path) as f:
        rows = [r for r in csv.DictReader(f) if r["label"] in (before, after)]
    cells: dict = {}
    for r in rows:
        cells.setdefault((r["dataset"], r["rel_bound"]), {})[r["label"]] = r
    print(
        "| field | E/range | payload after | ratio before -> after (SZ3) | decode MB/s | "
        "x SZ3 | x SPERR | bound held |"
    )
    print("|---|---:|---|---:|---:|---:|---:|---|")
    pairs = [(k, v) for k, v in cells.items() if before in v and after in v]
    for (name, rel), c in pairs:
        b, a = c[before], c[after]

        def two(key, fmt="{:.2f}"):
            return f"{fmt.format(float(b[key]))} -> {fmt.format(float(a[key]))}"

        held = "yes" if a["bound_ok_volpack"] == "True" == b["bound_ok_volpack"] else "NO"
        print(
            f"| {name} | {rel} | {a['path']} | {two('ratio_volpack')} ({float(a['ratio_sz3']):.2f}) "
            f"| {two('decode_MBps_volpack', '{:.0f}')} | {two('x_sz3')} | {two('x_sperr')} | {held} |"
        )
    for label in (before, after):
        got = [c[label] for _, c in pairs]
        half = sum(float(r["x_sz3"]) >= 0.5 for r in got)
        sperr = sum(float(r["x_sperr"]) >= 1.0 for r in got)
        above = sum(float(r["ratio_volpack"]) >= float(r["ratio_sz3"]) for r in got)
        gm = {
            k: math.exp(sum(math.log(float(r[k])) for r in got) / len(got))
            for k in ("x_sz3", "x_sperr")
        }
        print(
            f"\n{label}: >= 0.5x SZ3 in {half} of {len(got)} cells, >= SPERR in {sperr}, "
            f"ratio >= SZ3's in {above}; geometric mean x SZ3 {gm['x_sz3']:.3f}, "
            f"x SPERR {gm['x_sperr']:.3f}"
        )


if __name__ == "__main__":
    main(*sys.argv[1:])
