"""Tables, CSV and a chart from trial.py's JSON lines.

    python results/kinds37/summarise.py OUT.csv CHART.png RUN.jsonl [RUN.jsonl ...]

Prints markdown: integer volumes (ratio, best peer, x best peer, decode MB/s and x the best
peer's and JPEG-LS's) and float cells (ratio, the best of SZ3 and SPERR that held the bound,
x it, max error / bound, decode MB/s x that peer's). A later file's cell replaces an
earlier one's. Later trials (kinds38) call :func:`main` with their own name and lists.
"""

from __future__ import annotations

import csv
import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from make import HELD_OUT, MAKERS  # noqa: E402


def rows_of(paths, held=HELD_OUT, makers=MAKERS):
    cells = {}
    for p in paths:
        for line in open(p):
            c = json.loads(line)
            cells[c["name"], c["rel"]] = c
    rows = []
    for (name, rel), c in cells.items():
        j = c["json"]
        row = {
            "name": name,
            "set": "held" if name in held else "tuned" if name.split()[0] in makers else "late",
            "rel": rel or "",
        }
        if j is None:
            row["error"] = c.get("error", "")
            rows.append(row)
            continue
        row.update(shape="x".join(map(str, j["shape"])), dtype=j["dtype"], bytes=j["file_nbytes"],
                   ratio=round(j["ratio"], 4),
                   dec_mb_s=round(j.get("dec_mb_s_warm") or j["dec_mb_s"], 2))  # fmt: skip
        peers = j.get("peers", [])
        if rel:
            bound = j["compress"].get("error_bound")
            row["max_err_over_bound"] = float(f"{j['max_error'] / bound:.6g}") if bound else ""
            ok = [q for q in peers if q["name"] in ("sz3", "sperr") and q["bound_held"]]
            row["peers_broke"] = ";".join(q["name"] for q in peers if not q["bound_held"])
            row["psnr"] = round(j["psnr"], 2) if j.get("psnr") is not None else ""
        else:
            ok = [q for q in peers if q.get("lossless")]
            jls = [q for q in peers if q["name"] == "jpegls"]
            if jls:
                row["x_jpegls_dec"] = round(row["dec_mb_s"] / jls[0]["dec_mb_s"], 3)
        if j.get("peers_left_out"):
            row["peers_left_out"] = ";".join(map(str, j["peers_left_out"]))
        if ok:
            b = min(ok, key=lambda q: q["file_nbytes"])
            row.update(best_peer=b["name"], peer_ratio=round(b["ratio"], 4),
                       x_best=round(b["file_nbytes"] / j["file_nbytes"], 4),
                       peer_dec_mb_s=round(b["dec_mb_s"], 1),
                       x_peer_dec=round(row["dec_mb_s"] / b["dec_mb_s"], 3))  # fmt: skip
        rows.append(row)
    return rows


def main(trial: str = "kinds37", held=HELD_OUT, makers=MAKERS) -> None:
    out, chart, runs = sys.argv[1], sys.argv[2], sys.argv[3:]
    rows = rows_of(runs, held, makers)
    keys = list(dict.fromkeys(k for r in rows for k in r))
    with open(out, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=keys)
        w.writeheader()
        w.writerows(rows)
    ints = [r for r in rows if not r["rel"]]
    flts = [r for r in rows if r["rel"]]
    g = lambda r, k: r.get(k, "")  # noqa: E731
    if ints:
        print(
            "| volume | set | shape, dtype | ratio | best peer | x best peer | decode MB/s | x peer's | x JPEG-LS's |"
        )
        print("|---|---|---|---:|---|---:|---:|---:|---:|")
        for r in ints:
            if "error" in r:
                print(f"| {r['name']} | {r['set']} | | ERROR: {r['error']} | | | | | |")
                continue
            print(f"| {r['name']} | {r['set']} | {r['shape']} {r['dtype']} | {r['ratio']:.3f} | "
                  f"{g(r, 'best_peer')} {g(r, 'peer_ratio')} | {g(r, 'x_best')} | {r['dec_mb_s']:.1f} | "
                  f"{g(r, 'x_peer_dec')} | {g(r, 'x_jpegls_dec')} |")  # fmt: skip
        print()
    if flts:
        print(
            "| field | set | E / range | ratio | best of SZ3, SPERR | x best | max err / bound | decode MB/s | x peer's | peers that broke the bound |"
        )
        print("|---|---|---|---:|---|---:|---:|---:|---:|---|")
        for r in flts:
            if "error" in r:
                print(
                    f"| {r['name']} | {r['set']} | {r['rel']} | ERROR: {r['error']} | | | | | | |"
                )
                continue
            print(f"| {r['name']} | {r['set']} | {r['rel']} | {r['ratio']:.2f} | {g(r, 'best_peer')} "
                  f"{g(r, 'peer_ratio')} | {g(r, 'x_best')} | {g(r, 'max_err_over_bound')} | "
                  f"{r['dec_mb_s']:.1f} | {g(r, 'x_peer_dec')} | {g(r, 'peers_broke')} |")  # fmt: skip
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ok = [r for r in rows if r.get("x_best")]
    labels = [r["name"] + (f" {r['rel']}" if r["rel"] else "") for r in ok]
    fig, ax = plt.subplots(figsize=(10, 0.28 * len(ok) + 1.2))
    colors = [
        "tab:orange" if r["set"] == "held" else ("tab:blue" if not r["rel"] else "tab:green")
        for r in ok
    ]
    ax.barh(range(len(ok)), [r["x_best"] for r in ok], color=colors)
    ax.set_yticks(range(len(ok)), labels, fontsize=7)
    ax.invert_yaxis()
    for x, s in ((1.0, "k"), (1.1, "r")):
        ax.axvline(x, color=s, lw=0.8, ls="--")
    ax.set_xlabel(
        "volpack's ratio / the best peer's (integer: any lossless peer; float: SZ3 or SPERR that held the bound)"
    )
    ax.set_title(f"{trial}: blue integer, green float, orange held out")
    fig.tight_layout()
    fig.savefig(chart, dpi=110)


if __name__ == "__main__":
    main()
