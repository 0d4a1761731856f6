"""Markdown tables of the kinds34 CSVs (trial.csv, measure_trial.csv, measure_late.csv,
measure_corpus.csv). Run: ``python results/lossless/kinds34/summarise.py``."""

import csv
from pathlib import Path

HERE = Path(__file__).parent


def rows(name):
    with open(HERE / name) as f:
        return list(csv.DictReader(f))


trial = {r["volume"]: r for r in rows("trial.csv")}
after = {r["volume"]: r for r in rows("measure_trial.csv")}
print(
    "| volume | set | dtype, shape | ratio | best peer | x peer (trial) | x peer after | decode MB/s / JPEG-LS's |"
)
print("|---|---|---|---:|---|---:|---:|---|")
for v, t in trial.items():
    a = after.get(v, {})
    xa = a.get("x_peer_after", "")
    print(
        f"| {v} | {t['set']} | {t['shape']} | {t['ratio']} | {t['best_peer']} {float(t['peer_ratio']):.3f} | "
        f"{float(t['x_best_peer']):.3f} | {float(xa):.3f} | {t['dec_mb_s']} / {t['jpegls_dec_mb_s']} |"
    )
print()
print(
    "| volume | bytes before -> after | ratio before -> after | x best peer before -> after | encode CPU s | decode CPU s | bricks |"
)
print("|---|---|---|---|---|---|---|")
for name in ("measure_trial.csv", "measure_late.csv"):
    for r in rows(name):
        if r["same_file"] == "True":
            continue
        print(
            f"| {r['volume']} | {r['bytes_before']} -> {r['bytes_after']} | {float(r['ratio_before']):.1f} -> "
            f"{float(r['ratio_after']):.1f} | {r['best_peer']} {float(r['x_peer_before']):.3f} -> "
            f"{float(r['x_peer_after']):.3f} | {r['enc_cpu_before']} -> {r['enc_cpu_after']} | "
            f"{r['dec_cpu_before']} -> {r['dec_cpu_after']} | {r['tools_after']} |"
        )
print()
same = [r for r in rows("measure_trial.csv") if r["same_file"] == "True"]
eb = sum(float(r["enc_cpu_before"]) for r in same)
ea = sum(float(r["enc_cpu_after"]) for r in same)
print(f"unchanged trial volumes: {len(same)}; encode CPU {eb:.1f} -> {ea:.1f} s ({ea / eb:.3f}x)")
corpus = rows("measure_corpus.csv")
print(
    "corpus:",
    ", ".join(
        f"{r['volume']} {r['bytes_after']} ({'same' if r['same_file'] == 'True' and r['base_equal'] == 'True' else 'CHANGED'})"
        for r in corpus
    ),
)
eb = sum(float(r["enc_cpu_before"]) for r in corpus)
ea = sum(float(r["enc_cpu_after"]) for r in corpus)
print(f"corpus encode CPU {eb:.1f} -> {ea:.1f} s ({ea / eb:.3f}x, one run each)")
