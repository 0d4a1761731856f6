"""Tables of the session-26 check on synthetic fields no method was tuned on.

Made with ``python make.py`` (96^3 float32 fields: a log-normal density, precipitation,
a shock) and, for each field F and bound E in 1e-2..1e-5 of its range,
``volpack -q compare F.npy --rel-error E --peers --json > lossy/F-E.json``; integer copies
(shock as uint16 0..4000, precipitation as uint8, log of the density x 1000 as int16)
``volpack -q compare F.npy --peers --jpegxl-efforts 7,9,10 --json > lossless/F.json``.
Run: ``python summarise.py`` (prints markdown)."""

import json
from pathlib import Path

HERE = Path(__file__).parent
print("| field | E / range | volpack | SZ3 | SPERR | zfp | x best of SZ3, SPERR | decode MB/s volpack (kernels loaded) / SZ3 / SPERR |")
print("|---|---:|---:|---:|---:|---:|---:|---|")
for f in ("lognormal", "precip", "shock"):
    for e in ("1e-2", "1e-3", "1e-4", "1e-5"):
        r = json.loads((HERE / "lossy" / f"{f}-{e}.json").read_text())
        p = {x["name"]: x for x in r["peers"]}
        best = max(p["sz3"]["ratio"], p["sperr"]["ratio"])
        print(
            f"| {f} | {e} | {r['ratio']:.2f} | {p['sz3']['ratio']:.2f} | {p['sperr']['ratio']:.2f} | "
            f"{p['zfp']['ratio']:.2f} | {r['ratio'] / best:.3f} | {r['dec_mb_s_warm']:.0f} / "
            f"{p['sz3']['dec_mb_s']:.0f} / {p['sperr']['dec_mb_s']:.0f} |"
        )
print()
print("| volume | volpack | best peer | x best peer | JPEG-LS | decode MB/s volpack (kernels loaded) / JPEG-LS |")
print("|---|---:|---|---:|---:|---|")
for f in ("shock_u16", "precip_u8", "lognormal_i16"):
    r = json.loads((HERE / "lossless" / f"{f}.json").read_text())
    ps = sorted(r["peers"], key=lambda x: -x["ratio"])
    ls = next(x for x in ps if x["name"] == "jpegls")
    warm = r.get("dec_mb_s_warm")
    print(
        f"| {f} | {r['ratio']:.3f} | {ps[0]['name']} {ps[0]['ratio']:.3f} | {r['ratio'] / ps[0]['ratio']:.3f} | "
        f"{ls['ratio']:.3f} | {warm if warm is None else round(warm, 1)} / {ls['dec_mb_s']:.1f} |"
    )
