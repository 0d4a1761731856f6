"""Medians and paired differences of a bench_walk_served.py walk.csv (first tree against the second): python paired.py walk.csv"""
import csv, statistics, sys
r = list(csv.DictReader(open(sys.argv[1])))
sides = list(dict.fromkeys(x["side"] for x in r))
a, b = sides[0], sides[1]
for key in ("frame0_s", "whole_s"):
    m = [float(x[key]) for x in r if x["side"] == a]; n = [float(x[key]) for x in r if x["side"] == b]
    d = [y - x for x, y in zip(m, n)]
    print(f"{key}: {a} median {statistics.median(m):.3f} (range {min(m):.3f}-{max(m):.3f}), {b} {statistics.median(n):.3f} ({min(n):.3f}-{max(n):.3f}); paired {b}-{a} median {statistics.median(d):+.3f} s, {b} faster in {sum(v < 0 for v in d)} of {len(d)}")
