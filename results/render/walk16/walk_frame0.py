"""Frame 0 wall and CPU (ms) per round and configuration from bench_walk_cli's frames.csv,
and the later frames' CPU median."""
import csv
import statistics
import sys

rows = list(csv.DictReader(open(sys.argv[1])))
for v in dict.fromkeys(r["volume"] for r in rows):
    for c in dict.fromkeys(r["config"] for r in rows):
        fr = [r for r in rows if r["volume"] == v and r["config"] == c]
        f0 = [r for r in fr if r["frame"] == "0"]
        wall = [round(float(r["select_ms"]) + float(r["decode_ms"]) + float(r["render_ms"])) for r in f0]
        later = [float(r["cpu_ms"]) for r in fr if r["frame"] != "0"]
        print(f"{v} {c}: frame 0 wall {wall} ms, CPU {[round(float(r['cpu_ms'])) for r in f0]} ms;"
              f" decode wall {[round(float(r['decode_ms'])) for r in f0]}, render wall"
              f" {[round(float(r['render_ms'])) for r in f0]}; later frames CPU median"
              f" {statistics.median(later):.0f} ms ({min(later):.0f}-{max(later):.0f})")
