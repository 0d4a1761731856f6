"""Per stage of frame 0: CPU ms (and system CPU ms) per round, main against the branch,
from stages_*.csv (stages_sys.py's rows; its minor_faults column holds system CPU us)."""
import csv
import sys
from collections import defaultdict

rows = list(csv.DictReader(open(sys.argv[1])))
order = list(dict.fromkeys(r["stage"] for r in rows))
for run in dict.fromkeys(r["run"] for r in rows):
    print(f"\n{run}: CPU ms (system CPU ms) per round")
    cell = defaultdict(list)
    for r in rows:
        if r["run"] == run:
            cell[r["stage"], r["label"]].append(f"{float(r['cpu_ms']):.0f} ({int(r['minor_faults']) / 1000:.0f})")
    labels = list(dict.fromkeys(r["label"] for r in rows))
    print(f"{'stage':40s} " + " | ".join(f"{l:28s}" for l in labels))
    for s in order:
        print(f"{s:40s} " + " | ".join(f"{', '.join(cell[s, l]):28s}" for l in labels))
