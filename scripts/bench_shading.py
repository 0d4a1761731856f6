"""Shading inside pre-integrated segments, and transfer-function edits (table updates).

Part 1, shading accuracy (seed 000 5.2, seed 004 eq. 1.33-1.34, seed 001 5.2)
    Reference: post-classification with Phong evaluated at every sample, step 1/50.
    Compared at steps 2, 1 and 0.5 (reference lengths):

    ``post/phong``            post-classification, Phong at each sample;
    ``preint/phong``          exact pre-integrated segments shaded with the midpoint normal;
    ``preint/preintegrated``  lighting tables: ``n.l`` linear between the two end normals,
                              specular at the emission centroid (eqs. 1.33-1.34);
    ``preint/centroid``       Phong at the segment's emission centroid (from the same table).

    Volumes: ``waves`` (48^3, sin/cos products: smoothly turning normals), ``ball``
    (48^3 distance field), ``sh16`` (the spherical harmonic of scripts/bench_render.py),
    and the head CT (108 x 128 x 128) when fetched. TFs: ``ramp`` (smooth), ``spikes``
    (three narrow opacity peaks: emission concentrated inside a segment), ``hf`` (random
    high-frequency TF). 128 x 128 images, azimuth 30, elevation 20, ERT off.

Part 2, table updates (seed 001's CPU table-update timings, digest benchmark B8)
    :class:`volpack.render.preint.TableUpdater` at n = 64 .. 512, ``fast`` (no
    self-attenuation) and ``exact`` (with it), with and without the lighting channels:
    a global update (every TF entry changes: a full build) and local updates of one TF
    entry at every 8th position (the middle one touches the most, half the table).
    Seed 001: 256^2 table, ca 0.3 s / 20 s global and 0.15 s / 10 s local maximum,
    without / with self-attenuation, on a 650 MHz Athlon.

    python scripts/bench_shading.py [--out results/render] [--size 128]

Writes ``shading.csv``, ``updates.csv``, ``shading.png`` and ``shading.md`` to ``--out``.
"""

from __future__ import annotations

import argparse
import csv
import math
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "scripts"))

REF_STEP = 0.02
STEPS = [2.0, 1.0, 0.5]
MODES = {
    "post/phong": ("post", "phong"),
    "preint/phong": ("preintegrated", "phong"),
    "preint/preintegrated": ("preintegrated", "preintegrated"),
    "preint/centroid": ("preintegrated", "centroid"),
}
TABLE_SIZES = [64, 128, 256, 512]


def volumes():
    from bench_render import ct_volume, sh_volume

    z, y, x = np.mgrid[:48, :48, :48].astype(np.float32)
    yield "waves", (np.sin(z / 2.5) * np.cos(y / 3.1) + np.sin(x / 2.2)) * 50.0, (1.0,) * 3
    r = np.sqrt((z - 23.5) ** 2 + (y - 23.5) ** 2 + (x - 23.5) ** 2)
    yield "ball", r, (1.0,) * 3
    yield "sh16", sh_volume(), (1.0,) * 3
    try:
        ct, sp = ct_volume()
    except Exception as e:  # the CT is optional: scripts/fetch_data.py ct_head
        print(f"head CT skipped ({e})", flush=True)
    else:
        yield "ct_head", ct, sp


def tfs(seed: int = 7):
    s = np.linspace(0.0, 1.0, 256)
    rng = np.random.default_rng(seed)
    ramp = np.stack([s, 1 - s, 0 * s + 0.5, 0.5 * np.clip(2 * s - 1, 0, 1)], 1)
    peaks = np.array([0.3, 0.6, 0.8])
    spikes = np.stack(
        [s, 1 - s, 0 * s + 0.5, 0.8 * np.exp(-(((s[:, None] - peaks) / 0.01) ** 2)).max(1)], 1
    )
    hf = np.concatenate([rng.random((256, 3)), (rng.random((256, 1)) > 0.85) * 0.6], 1)
    return {"ramp": ramp, "spikes": spikes, "hf": hf}


def rmse(a, b) -> float:
    d = a[..., :3].astype(np.float64) - b[..., :3]
    return float(np.sqrt(np.mean(d * d)))


def bench_accuracy(size: int, workers: int):
    from volpack.render.camera import Camera
    from volpack.render.raycast import render

    cam = Camera(azimuth=30.0, elevation=20.0, size=(size, size))
    rows = []
    for vname, vol, sp in volumes():
        vol = np.ascontiguousarray(vol, np.float32)
        for tname, tab in tfs().items():
            kw = dict(spacing=sp, tf=tab, camera=cam, ert=1.0, workers=workers, render_stats=True)
            ref, _ = render(vol, step=REF_STEP, classification="post", shading="phong", **kw)
            for label, (cls, shading) in MODES.items():
                render(
                    vol, step=1.0, classification=cls, shading=shading, preint_method="exact", **kw
                )
                for step in STEPS:
                    img, st = render(vol, step=step, classification=cls, shading=shading,
                                     preint_method="exact", **kw)  # fmt: skip
                    e = rmse(img, ref)
                    rows.append({"volume": vname, "tf": tname, "mode": label, "step": step,
                                 "rmse": round(e, 6),
                                 "psnr": round(99.0 if e == 0 else 20 * math.log10(1 / e), 3),
                                 "seconds": round(st.seconds, 4)})  # fmt: skip
            line = "  ".join(
                f"{m.split('/')[1][:6]} {r['psnr']:.2f}"
                for m in MODES
                for r in rows[-len(MODES) * len(STEPS) :]
                if r["mode"] == m and r["step"] == 1.0
            )
            print(f"{vname}/{tname} step 1 PSNR: {line}", flush=True)
    return rows


def bench_updates(repeat: int):
    from volpack.render.preint import TableUpdater
    from volpack.render.transfer import preset

    rows = []
    for n in TABLE_SIZES:
        base = np.asarray(preset("ct-bone", -1000.0, 2000.0).table(-1000.0, 2000.0, n), float)
        for method in ("fast", "exact"):
            for lighting in (False, True):
                TableUpdater(base[:8], 1.0, method, lighting=lighting)  # JIT warm-up
                best = math.inf
                for _ in range(repeat):
                    t = time.perf_counter()
                    up = TableUpdater(base, 1.0, method, lighting=lighting)
                    best = min(best, time.perf_counter() - t)
                local = []
                for k in range(0, n, 8):
                    edited = up._tab.copy()
                    edited[k, 3] = 0.5 * edited[k, 3] + 0.25
                    t = time.perf_counter()
                    count = up.update(edited)
                    local.append((time.perf_counter() - t, count, k))
                worst = max(local)
                rows.append({"n": n, "method": method, "lighting": lighting,
                             "global_s": round(best, 6), "local_max_s": round(worst[0], 6),
                             "local_median_s": round(float(np.median([x[0] for x in local])), 6),
                             "local_max_entries": max(x[1] for x in local),
                             "entries": n * n})  # fmt: skip
                r = rows[-1]
                print(f"  n={n:4d} {method:5s} lighting={lighting!s:5s} global {r['global_s']:.4f} s"
                      f"  local max {r['local_max_s']:.4f} s  median {r['local_median_s']:.4f} s",
                      flush=True)  # fmt: skip
    return rows


def plot(rows, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    cases = sorted({(r["volume"], r["tf"]) for r in rows}, key=lambda c: (c[0], c[1]))
    fig, ax = plt.subplots(figsize=(11, 4.5))
    width = 0.8 / len(MODES)
    for k, mode in enumerate(MODES):
        vals = [next(r["psnr"] for r in rows if (r["volume"], r["tf"]) == c and r["mode"] == mode
                     and r["step"] == 1.0) for c in cases]  # fmt: skip
        ax.bar(np.arange(len(cases)) + k * width, vals, width, label=mode)
    ax.set_xticks(np.arange(len(cases)) + 0.4 - width / 2)
    ax.set_xticklabels([f"{v}\n{t}" for v, t in cases], fontsize=8)
    ax.set_ylabel("PSNR vs per-sample Phong at step 1/50 (dB)")
    ax.set_title("Shading inside segments, step 1 (higher is better)")
    lo = min(r["psnr"] for r in rows if r["step"] == 1.0)
    ax.set_ylim(lo - 3, None)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def write_md(rows, urows, args, path):
    out = ["# Shading inside pre-integrated segments; table updates", "",
           f"Written by `scripts/bench_shading.py` ({args.size} x {args.size} images, "
           f"reference per-sample Phong at step {REF_STEP}). PSNR in dB on pre-multiplied "
           "RGB over black.", "",
           "| volume | tf | step | " + " | ".join(MODES) + " |",
           "|---|---|---:|" + "---:|" * len(MODES)]  # fmt: skip
    cases = sorted({(r["volume"], r["tf"]) for r in rows})
    wins = {m: 0 for m in MODES}
    for v, t in cases:
        for step in STEPS:
            sel = {r["mode"]: r["psnr"] for r in rows
                   if (r["volume"], r["tf"], r["step"]) == (v, t, step)}  # fmt: skip
            wins[max(sel, key=sel.get)] += 1
            out.append(
                f"| {v} | {t} | {step:g} | " + " | ".join(f"{sel[m]:.2f}" for m in MODES) + " |"
            )
    out += ["", "Best mode per row: " + ", ".join(f"{m} {k}" for m, k in wins.items()) + ".", "",
            "## Table updates (seconds)", "",
            "Global: every entry rebuilt (TableUpdater construction, best of "
            f"{args.repeat}). Local: one TF entry edited, at every 8th position; the "
            "maximum is where the most segments cross it (about half the table).", "",
            "| n | method | lighting | global | local max | local median | entries touched (max) |",
            "|---:|---|---|---:|---:|---:|---:|"]  # fmt: skip
    for r in urows:
        out.append(f"| {r['n']} | {r['method']} | {'yes' if r['lighting'] else 'no'} | "
                   f"{r['global_s']:.4f} | {r['local_max_s']:.4f} | {r['local_median_s']:.4f} | "
                   f"{r['local_max_entries']:,} of {r['entries']:,} |")  # fmt: skip
    path.write_text("\n".join(out) + "\n")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=ROOT / "results" / "render")
    ap.add_argument("--size", type=int, default=128)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--workers", type=int, default=0)
    args = ap.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    print("table updates:", flush=True)
    urows = bench_updates(args.repeat)
    rows = bench_accuracy(args.size, args.workers)
    for name, data in (("shading.csv", rows), ("updates.csv", urows)):
        with open(args.out / name, "w", newline="") as f:
            wr = csv.DictWriter(f, fieldnames=list(data[0]))
            wr.writeheader()
            wr.writerows(data)
    plot(rows, args.out / "shading.png")
    write_md(rows, urows, args, args.out / "shading.md")
    print(f"wrote {args.out}", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
