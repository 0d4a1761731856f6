"""qver26: volpack's size before (v6 = main) and after (A = this branch) against the best
peer (smallest of SZ3, SZ3-best and SPERR at the same bound, over every results/lossy CSV)."""
import csv
import glob
import sys
from collections import defaultdict

sizes = defaultdict(dict)  # (field, rel) -> {version: bytes}
for path in sys.argv[1:]:
    for r in csv.DictReader(open(path)):
        sizes[(r["field"], float(r["rel"]))][r["version"]] = int(r["bytes"])
peers = defaultdict(lambda: 1 << 62)
ranges = {}
for path in glob.glob("results/lossy/**/lossy.csv", recursive=True):
    for r in csv.DictReader(open(path)):
        if r["method"] in ("sz3", "sz3-best", "sperr") and r["setting"].startswith("E="):
            vr, e = float(r["value_range"]), float(r["bound"])
            if vr > 0:
                rel = float(f"{e / vr:.0e}")
                key = (r["dataset"], rel)
                peers[key] = min(peers[key], int(r["compressed_bytes"]))
print("field,rel,before,after,best_peer,before_x,after_x")
for (f, rel), v in sizes.items():
    p = peers.get((f, rel))
    if "6" in v and "A" in v and p:
        print(f"{f},{rel:g},{v['6']},{v['A']},{p},{p / v['6']:.3f},{p / v['A']:.3f}")
