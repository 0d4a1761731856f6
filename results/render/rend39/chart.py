"""Chart of split.txt (session 39, rend39): each volume's opaque frame (one thread, CPU
ms) cut into the per-ray set-up (the set-up kernel), refinement (the frame less the
frame with ``refine=1``) and the rest (the march of segments, tests, jumps and the
visible segments' look-ups and compositing).

    python results/render/rend39/chart.py   # reads split.txt, writes split.png
"""

import re
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

HERE = Path(__file__).resolve().parent


def parse():
    rows, cur = {}, None
    for line in (HERE / "split.txt").read_text().splitlines():
        m = re.match(r"(\S+): rays traced", line)
        if m:
            cur = m.group(1)
            rows[cur] = {}
            continue
        m = re.match(r"\s+(.+?)\s+cpu\s+([\d.]+) ms", line)
        if m and cur:
            rows[cur][m.group(1).strip()] = float(m.group(2))
    return rows


def main():
    rows = parse()
    labels, parts = [], {"per-ray set-up": [], "refinement": [], "the rest": []}
    for v, r in rows.items():
        for sh in ("none", "phong"):
            f, f1, s = r[f"frame {sh}"], r[f"refine=1 {sh}"], r["set-up"]
            labels.append(f"{v}\n{sh}")
            parts["per-ray set-up"].append(s)
            parts["refinement"].append(f - f1)
            parts["the rest"].append(f1 - s)
    fig, ax = plt.subplots(figsize=(8, 4))
    bottom = [0.0] * len(labels)
    for k, vals in parts.items():
        ax.bar(labels, vals, bottom=bottom, label=k)
        bottom = [b + x for b, x in zip(bottom, vals)]
    ax.set_ylabel("CPU ms a frame (one thread)")
    ax.set_title("Opaque frames, 512^2, step 0.5: where the time goes")
    ax.legend()
    fig.tight_layout()
    fig.savefig(HERE / "split.png", dpi=100)


if __name__ == "__main__":
    main()
