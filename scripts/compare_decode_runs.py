"""Two labelled runs of ``scripts/bench_lossy_decode.py`` side by side, per cell.

Reads its ``decode.csv`` files, or its printed logs (``*.log``: one line per cell, for
runs stopped before they wrote their CSV; the log's file name, without ``.log``, is
its label).

For each (field, bound) in both runs: volpack's ratio, payload path, decode and encode
MB/s before -> after, and its decoding speed relative to SPERR's and SZ3's measured in
the same process (``x_sperr``, ``x_sz3``: the figures that survive a shared machine);
then the geometric means of the after / before ratios and how many cells reach the
issue's goals (decode >= SPERR's, >= half SZ3's).

    python scripts/compare_decode_runs.py results/lossy/lossy11/speed/before.log \\
        results/lossy/lossy11/speed/after.log --out results/lossy/lossy11/speed/compare.md
"""

from __future__ import annotations

import argparse
import csv
import math
import re
from pathlib import Path

# A cell's line in the log (bench_lossy_decode.run's print).
LINE = re.compile(
    r"^(?P<dataset>\S+)\s+(?P<rel>\S+) (?P<path>.+?)\s+ratio\s+(?P<ratio>\S+) \| MB/s volpack\s+"
    r"(?P<v>\S+) sperr\s+(?P<s>\S+) sz3\s+(?P<z>\S+) \| x SPERR (?P<xs>\S+) x SZ3 (?P<xz>\S+)"
    r"(?: \| encode MB/s (?P<enc>\S+) \(x SZ3 (?P<exz>\S+)\))?"
)


def log_rows(path: Path) -> list[dict]:
    rows = []
    for line in path.read_text().splitlines():
        m = LINE.match(line)
        if m:
            rows.append({
                "label": path.stem, "dataset": m["dataset"], "rel_bound": f"{float(m['rel']):g}",
                "path": m["path"].strip(), "ratio_volpack": m["ratio"], "decode_MBps_volpack": m["v"],
                "x_sperr": m["xs"], "x_sz3": m["xz"], "encode_MBps_volpack": m["enc"] or "",
                "enc_x_sz3": m["exz"] or "",
            })  # fmt: skip
    return rows


def rows_of(paths: list[Path]) -> list[dict]:
    rows = []
    for p in paths:
        if p.suffix == ".log":
            rows += log_rows(p)
            continue
        with p.open() as f:
            rows += list(csv.DictReader(f))
    return rows


def geomean(xs: list[float]) -> float:
    return math.exp(sum(math.log(x) for x in xs) / len(xs)) if xs else float("nan")


def compare(rows: list[dict], before: str, after: str) -> str:
    by = {(r["label"], r["dataset"], r["rel_bound"]): r for r in rows}
    cells = [(d, b) for (lab, d, b) in by if lab == after and (before, d, b) in by]
    out = [
        f"volpack `{before}` -> `{after}` (decode and encode MB/s in CPU time, one core; "
        "x SPERR / x SZ3: volpack's decode speed over the peer's, same process)",
        "",
        "| field | bound | path after | ratio | decode MB/s | x SPERR | x SZ3 | encode MB/s |",
        "|---|---|---|---|---|---|---|---|",
    ]
    keys = ("ratio_volpack", "x_sperr", "x_sz3", "enc_x_sz3")
    gains = {k: [] for k in keys}
    moved = {k: [] for k in keys}  # the cells whose coding changed (ratio or path)
    goals = {before: [0, 0], after: [0, 0]}
    for d, b in cells:
        r0, r1 = by[(before, d, b)], by[(after, d, b)]
        changed = r0["path"] != r1["path"] or r0["ratio_volpack"] != r1["ratio_volpack"]
        for k in keys:
            if r0.get(k) and r1.get(k):
                gains[k].append(float(r1[k]) / float(r0[k]))
                if changed:
                    moved[k].append(gains[k][-1])
        for lab, r in ((before, r0), (after, r1)):
            goals[lab][0] += float(r["x_sperr"]) >= 1.0
            goals[lab][1] += float(r["x_sz3"]) >= 0.5

        def pair(k, fmt="{:.2f}"):
            return f"{fmt.format(float(r0[k]))} -> {fmt.format(float(r1[k]))}" if r0.get(k) and r1.get(k) else ""

        out.append(
            f"| {d} | {b} | {r1['path']} | {pair('ratio_volpack', '{:.3f}')} | "
            f"{pair('decode_MBps_volpack', '{:.1f}')} | {pair('x_sperr')} | {pair('x_sz3')} | "
            f"{pair('encode_MBps_volpack')} |"
        )
    out += [
        "",
        f"{len(cells)} cells; geometric mean after / before: ratio {geomean(gains['ratio_volpack']):.4f}, "
        f"decode speed (relative to SPERR's) {geomean(gains['x_sperr']):.3f}, "
        f"(relative to SZ3's) {geomean(gains['x_sz3']):.3f}, "
        f"encode speed (relative to SZ3's) {geomean(gains['enc_x_sz3']):.3f}.",
        f"The {len(moved['ratio_volpack'])} cells whose coding changed: ratio "
        f"{geomean(moved['ratio_volpack']):.4f}, decode speed (relative to SPERR's) "
        f"{geomean(moved['x_sperr']):.3f}, (relative to SZ3's) {geomean(moved['x_sz3']):.3f}; "
        "the others' spread is the machine's noise.",
        f"Decode >= SPERR's: {goals[before][0]} -> {goals[after][0]} cells; "
        f">= half SZ3's: {goals[before][1]} -> {goals[after][1]} cells.",
    ]
    return "\n".join(out) + "\n"


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("csv", nargs="+", type=Path)
    ap.add_argument("--before", default="before")
    ap.add_argument("--after", default="after")
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args(argv)
    text = compare(rows_of(args.csv), args.before, args.after)
    print(text)
    if args.out:
        args.out.write_text(text)


if __name__ == "__main__":
    main()
