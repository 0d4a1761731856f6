"""The README's table: peer bits / volpack bits at the peer's PSNR (volpack's PSNR-mode
curve, volpack-psnr, interpolated), whole fields (base_both) and 64^3 crops (crop64).

    python results/lossy/psnr37/readme_table.py
"""

from pathlib import Path

HERE = Path(__file__).resolve().parent


def rows(path):
    out = {}
    for line in (HERE / path / "equal_psnr.md").read_text().splitlines():
        c = [x.strip() for x in line.strip("|").split("|")]
        if len(c) == 8 and c[1] == "volpack-psnr":
            out.setdefault(c[0], []).append((c[2], c[3], c[4], c[7]))
    return out


whole, crop = rows("base_both"), rows("crop64")
print("| field | TTHRESH 40 / 60 / 80 / 100 dB, whole field | zfp, whole field | TTHRESH 40 / 60 / 80, 64^3 crop | zfp, crop |")
print("|---|---|---|---|---|")
for f in dict.fromkeys([*whole, *crop]):
    cells = []
    for src in (whole, crop):
        got = src.get(f, [])
        tt = {s: x for p, s, _, x in got if p == "tthresh"}
        cells.append(" / ".join(tt.get(f"PSNR={t}", "-") for t in (40, 60, 80, 100)[: 4 if src is whole else 3]))
        cells.append(" / ".join(x for p, _, _, x in got if p == "zfp") or "-")
    print(f"| {f} | " + " | ".join(cells) + " |")
