"""Put new volpack rows beside an earlier run's peer rows, and compare the leads.

The peers' ratios do not depend on volpack's code, so a branch's run of ``--methods
volpack`` is set against the SPERR and SZ3 rows of a run made on main (same script, same
arrays), instead of running every peer again:

    python scripts/lossy18_merge.py --peers results/lossy/floats17/lossy.csv \\
        --volpack results/lossy/lossy18/floats_volpack/lossy.csv \\
        --out results/lossy/lossy18/floats/merged.csv
    python scripts/bench_lossy.py --from-csv results/lossy/lossy18/floats/merged.csv

Prints, per field and bound, volpack's lead (ratio / best of sperr, sz3, sz3-best) in
the peers' run and in the merged one, and the count at 1.1x and the geometric mean.
"""

from __future__ import annotations

import argparse
import csv
import math
from pathlib import Path

PEERS = ("sperr", "sz3", "sz3-best")


def read(path: Path) -> list[dict]:
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def leads(rows: list[dict]) -> dict:
    """{(dataset, bound): (volpack ratio, lead)} of the rows with a bound."""
    best, ours = {}, {}
    for r in rows:
        if not r["bound"]:
            continue
        key = (r["dataset"], float(r["bound"]))
        if r["method"] in PEERS:
            best[key] = max(best.get(key, 0.0), float(r["ratio"]))
        elif r["method"] == "volpack":
            ours[key] = float(r["ratio"])
    return {k: (v, v / best[k]) for k, v in ours.items() if k in best}


def summary(lead: dict) -> str:
    xs = [v[1] for v in lead.values()]
    gm = math.exp(sum(math.log(x) for x in xs) / len(xs))
    hits = sum(x >= 1.1 for x in xs)
    return f"{hits} of {len(xs)} at 1.1x, geomean {gm:.3f}, lowest {min(xs):.3f}"


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--peers", type=Path, required=True, help="a lossy.csv with the peers' rows")
    p.add_argument("--volpack", type=Path, required=True, help="a lossy.csv with volpack's")
    p.add_argument("--out", type=Path, required=True, help="the merged lossy.csv")
    a = p.parse_args()
    base, new = read(a.peers), read(a.volpack)
    fresh = {(r["dataset"], r["setting"]): r for r in new if r["method"] == "volpack"}
    merged = []
    for r in base:
        if r["method"] == "volpack":
            r = fresh.pop((r["dataset"], r["setting"]), None)
            if r is None:
                continue
        merged.append(r)
    if fresh:
        raise SystemExit(f"volpack rows without peers: {sorted(fresh)}")
    a.out.parent.mkdir(parents=True, exist_ok=True)
    with open(a.out, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(base[0]))
        w.writeheader()
        w.writerows(merged)
    before, after = leads(base), leads(merged)
    for key in before:
        (r0, l0), (r1, l1) = before[key], after[key]
        mark = "" if abs(r1 / r0 - 1) < 1e-4 else " *"
        print(
            f"{key[0]:18s} {key[1]:<10.4g} ratio {r0:8.2f} -> {r1:8.2f}  "
            f"lead {l0:.3f} -> {l1:.3f}{mark}"
        )
    print(f"before: {summary(before)}")
    print(f"after:  {summary(after)}")
    print(f"wrote {a.out} ({len(merged)} rows)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
