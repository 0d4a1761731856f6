"""Tables of the session-28 check on volumes no method was tuned on (``make.py``,
``run.sh``). Run: ``python results/unseen28/summarise.py`` (prints markdown)."""

import json
from pathlib import Path

HERE = Path(__file__).parent
LOSSLESS = ("ct_x16", "ct_u16off", "ct_i32", "ct_f32int", "ct_f64int", "mri_even", "mri_T",
            "mri_thin", "bs_noise", "dip_be", "mri_scaled")  # fmt: skip

print("| volume | dtype | volpack | best peer | x best peer | decode MB/s volpack (kernels loaded) / JPEG-LS |")
print("|---|---|---:|---|---:|---|")
for f in LOSSLESS:
    r = json.loads((HERE / "lossless" / f"{f}.json").read_text())
    ps = sorted(r["peers"], key=lambda x: -x["ratio"])
    ls = [x for x in ps if x["name"] == "jpegls"]
    jls = f"{ls[0]['dec_mb_s']:.1f}" if ls else "(not run)"
    print(
        f"| {f} | {r['dtype']} | {r['ratio']:.3f} | {ps[0]['name']} {ps[0]['ratio']:.3f} | "
        f"{r['ratio'] / ps[0]['ratio']:.3f} | {r['dec_mb_s_warm']:.1f} / {jls} |"
    )
print()
print("| field | E / range | volpack | SZ3 | SPERR | zfp | x best of SZ3, SPERR | PSNR volpack / best (dB) | decode MB/s volpack (kernels loaded) / SZ3 / SPERR |")
print("|---|---:|---:|---:|---:|---:|---:|---|---|")
for f in ("turb", "orbital", "mixing"):
    for e in ("1e-2", "1e-3", "1e-4", "1e-5"):
        r = json.loads((HERE / "lossy" / f"{f}-{e}.json").read_text())
        p = {x["name"]: x for x in r["peers"]}
        best = max((p["sz3"], p["sperr"]), key=lambda x: x["ratio"])
        print(
            f"| {f} | {e} | {r['ratio']:.2f} | {p['sz3']['ratio']:.2f} | {p['sperr']['ratio']:.2f} | "
            f"{p['zfp']['ratio']:.2f} | {r['ratio'] / best['ratio']:.3f} | {r['psnr']:.1f} / "
            f"{best['psnr']:.1f} | {r['dec_mb_s_warm']:.0f} / {p['sz3']['dec_mb_s']:.0f} / "
            f"{p['sperr']['dec_mb_s']:.0f} |"
        )
