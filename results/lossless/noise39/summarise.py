"""Markdown tables of `volpack -q compare ... --json` runs (one JSON object after
another), before and after: bits/voxel, ratio, the best peer and volpack's ratio over
it, over JPEG-XL e10 (decode speed: decode_ab.py, one process).

    python results/lossless/noise39/summarise.py NAMES PEERS.jsonl BEFORE.jsonl AFTER.jsonl

NAMES: the volumes in the files' order, comma-separated (heldout.sh's order:
carp_u16,bunny_u16,mra_u16,us_u8,radar_u8,rock_u8,lobster_u8); PEERS: runs with
--peers (their peers' lines are used), BEFORE and AFTER: volpack's runs.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path


def runs(path):
    text, dec, pos, out = Path(path).read_text(), json.JSONDecoder(), 0, []
    while True:
        while pos < len(text) and text[pos].isspace():
            pos += 1
        if pos >= len(text):
            return dict(zip(NAMES, out))
        obj, pos = dec.raw_decode(text, pos)
        out.append(obj)


NAMES = sys.argv[1].split(",")
peers_of = runs(sys.argv[2])
before = runs(sys.argv[3])
after = runs(sys.argv[4])
print(
    "| volume | shape dtype | bits/voxel before | after | best peer | x best before | after | x JPEG-XL e10 after |"
)
print("|---|---|---:|---:|---|---:|---:|---:|")
for name, b in before.items():
    a = after[name]
    peers = [p for p in peers_of[name]["peers"] if p.get("lossless") and p.get("ratio")]
    best = max(peers, key=lambda p: p["ratio"])
    e10 = next((p for p in peers if p["name"] == "jpegxl-e10"), None)
    rb, ra = b["compress"]["file_ratio"], a["compress"]["file_ratio"]
    shape = "x".join(map(str, b["shape"])) + " " + b["dtype"]
    x10 = f"{ra / e10['ratio']:.4f}" if e10 else "-"
    print(
        f"| {name} | {shape} | {b['bpv']:.4f} | {a['bpv']:.4f} | {best['name']} {best['ratio']:.4f} | "
        f"{rb / best['ratio']:.4f} | {ra / best['ratio']:.4f} | {x10} |"
    )
