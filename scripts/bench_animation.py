"""Animation benchmark: volpack's I/P/B coding with motion compensation, the thesis's
tables, and per-frame / 4-D peers at equal maximum error and at equal PSNR.

    python scripts/bench_animation.py            # every part (about 10-20 min on a busy 2-core box)
    python scripts/bench_animation.py --quick    # smaller animations, fewer settings

Animations (``volpack.synth``, (t, z, y, x) uint8 unless said; frame counts chosen so an
IBBPBBPBB GOP has one I-frame):

* ``head-subvoxel``  the bundled head MRI (84 x 128 x 128) moving (0.5, 0.25, 0.75)
  voxels per frame along (z, y, x), band-limited shift, seen through its centred 64^3
  (content from outside enters the view); 9 frames
* ``head-halfvoxel`` the same moving (0.5, 0.5, 0.5) voxels per frame
* ``head-rotate``    the crop turning 2 degrees per frame about z
* ``blob``           a soft sphere growing 0.75 voxels per frame
* ``advect``         a smooth random field carried by a swirling flow (<= 0.6 voxel/frame)
* ``fmri``           nibabel's ``tests/data/functional.nii``: real BOLD fMRI, 20 frames of
  3 x 21 x 17 int16 (stored values)
* ``advect-128``     the advected field at 128^3 (decode speed)

Parts, each a CSV in ``results/animation`` and a section of ``table.md``:

1. ``gops.csv``      (Table 2.11) GOPs I, IPP, IBB, IBBPBBPBB at quality 255 and 15 and
   at a max error: ratio, PSNR, max error, PSNR per frame type.
2. ``wavelets.csv``  (Table 2.9) wavelets 5/3, 2/6, Haar, 9/7-M at quality 255, IBBPBBPBB:
   PSNR of I, P and B frames and ratio.
3. ``coders.csv``    (Table 2.10) quality 255..15, arithmetic vs Huffman coder, IBBPBBPBB,
   2/6 wavelet on ``advect-128``: ratio, PSNR and decode frames/s on one thread.
4. ``peers.csv``     volpack IBBPBBPBB and I-only with ``max_error=E`` against per-frame
   zfp (tolerance E), SZ3 (ABS E), SPERR (absolute E) and SZ3 on the whole 4-D array:
   ratio, PSNR, max error (every voxel, float64). Equal-PSNR ratios are interpolated from
   the same sweep (log ratio linear in PSNR).
5. ``speed.csv``     decode frames/s (CPU and wall) of ``advect-128`` at max error 2,
   IBBPBBPBB, with the default motion (quarter voxels, half tried per frame), half voxels,
   and half voxels with block compensation.
6. ``motion.csv``    vector precision (whole / half / quarter), compensation (windowed /
   block) and search (fast / exhaustive) at one max error.
7. ``tools.csv``     what each tool adds on the moving heads, IBBPBBPBB at max errors 1,
   2, 4 and 9 against I-only: whole-frame shifts on / off and the anchoring I-frames'
   tighter bound on / off.

Charts: ``psnr_per_frame.png`` (PSNR of every frame per GOP), ``ratio_vs_psnr.png`` (per
GOP and peer). Peers get float32 copies of integer frames (as in ``bench_lossy.py``).
"""

from __future__ import annotations

import argparse
import csv
import io
import math
import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

ROOT = Path(__file__).resolve().parent.parent
GOPS = ("I", "IPP", "IBB", "IBBPBBPBB")
QUALITIES = (255, 127, 63, 31, 15)
WAVELETS = ("53", "26", "haar", "97m")


def log(msg: str) -> None:
    print(msg, file=sys.stderr, flush=True)


def load_fmri() -> np.ndarray:
    import nibabel

    from volpack import io as vio

    path = os.path.join(os.path.dirname(nibabel.__file__), "tests", "data", "functional.nii")
    return np.ascontiguousarray(vio.read_volume(path).data)


def animations(quick: bool) -> dict[str, np.ndarray]:
    from volpack import synth

    n = 32 if quick else 64
    head = synth.head((n, n, n))
    whole = synth.head((84, 128, 128))
    view = (n, n, n)
    out = {
        "head-subvoxel": synth.translate(whole, 9, step=(0.5, 0.25, 0.75), crop=view),
        "head-halfvoxel": synth.translate(whole, 9, step=(0.5, 0.5, 0.5), crop=view),
        "head-rotate": synth.rotate(head, 9, degrees=2.0),
        "blob": synth.blob((n, n, n), 9),
        "advect": synth.advect((n, n, n), 9),
    }
    try:
        out["fmri"] = load_fmri()
    except Exception as e:  # nibabel's test data missing: keep the rest
        log(f"fmri skipped: {e}")
    return out


def value_range(a: np.ndarray) -> float:
    return float(a.max()) - float(a.min())


def psnr(a: np.ndarray, b: np.ndarray, peak: float) -> float:
    mse = float(np.mean((a.astype(np.float64) - b.astype(np.float64)) ** 2))
    return math.inf if mse == 0 else 10 * math.log10(peak * peak / mse)


# -- volpack ---------------------------------------------------------------------------


def run_volpack(a: np.ndarray, decodes: int = 1, **kw) -> dict:
    """Code ``a`` with ``animation.compress(**kw)``, decode it ``decodes`` times and
    measure. Decode speed is the CPU time of this single-threaded process (the best
    run): on a shared machine wall time mostly measures the neighbours."""
    from volpack.animation import stream as animation

    buf = io.BytesIO()
    t0 = time.perf_counter()
    stats = animation.compress(a, buf, **kw)
    enc = time.perf_counter() - t0
    blob = buf.getvalue()
    dec, wall = math.inf, math.inf
    for _ in range(decodes):
        t0, c0 = time.perf_counter(), time.process_time()
        with animation.AnimationReader(blob) as r:
            out = r.frames()
        dec = min(dec, time.process_time() - c0)
        wall = min(wall, time.perf_counter() - t0)
    peak = value_range(a)
    err = np.abs(out.astype(np.float64) - a.astype(np.float64))
    per_type: dict[str, list[float]] = {}
    frame_psnr = []
    for t, row in enumerate(stats["frames"]):
        p = psnr(out[t], a[t], peak)
        frame_psnr.append(p)
        per_type.setdefault(row["type"], []).append(p)
    return {
        "nbytes": len(blob),
        "ratio": a.nbytes / len(blob),
        "psnr": psnr(out, a, peak),
        "max_error": float(err.max()),
        "encode_s": enc,
        "decode_cpu_s": dec,
        "decode_wall_s": wall,
        "decode_fps": len(a) / dec,
        "psnr_I": _mean(per_type.get("I")),
        "psnr_P": _mean(per_type.get("P")),
        "psnr_B": _mean(per_type.get("B")),
        "types": "".join(r["type"] for r in stats["frames"]),
        "frame_psnr": frame_psnr,
        "motion_bytes": stats["motion_nbytes"],
        "intra_blocks": stats["block_modes"].get("intra", 0),
    }


def _mean(v):
    if not v:
        return None
    finite = [x for x in v if math.isfinite(x)]
    return float(np.mean(finite)) if finite else math.inf


# -- peers -----------------------------------------------------------------------------


def peers() -> dict:
    import bench_lossy

    out = {}
    for name, make in (
        ("zfp", bench_lossy._zfp_method),
        ("sz3", bench_lossy._sz3_method),
        ("sperr", bench_lossy._sperr_method),
    ):
        try:
            m = make()
            probe = np.linspace(0, 1, 4096, dtype=np.float32).reshape(16, 16, 16)
            m.decode(m.encode(probe, 0.01)[0], probe)
            out[name] = m
        except Exception as e:
            log(f"{name} skipped: {type(e).__name__}: {e}")
    return out


def run_peer(m, a: np.ndarray, e: float, whole: bool = False) -> dict:
    x = a.astype(np.float32 if a.dtype.itemsize <= 2 else np.float64)
    parts = [x] if whole else list(x)
    nbytes, outs = 0, []
    t0 = time.perf_counter()
    blobs = []
    for p in parts:
        b, n = m.encode(np.ascontiguousarray(p), e)
        nbytes += n
        blobs.append(b)
    enc = time.perf_counter() - t0
    c0 = time.process_time()
    for b, p in zip(blobs, parts):
        outs.append(np.asarray(m.decode(b, p)).reshape(p.shape))
    dec = time.process_time() - c0
    out = outs[0] if whole else np.stack(outs)
    err = np.abs(out.astype(np.float64) - a.astype(np.float64))
    return {
        "nbytes": nbytes,
        "ratio": a.nbytes / nbytes,
        "psnr": psnr(out, a, value_range(a)),
        "max_error": float(err.max()),
        "encode_s": enc,
        "decode_cpu_s": dec,
        "decode_fps": len(a) / max(dec, 1e-9),
    }


# -- parts ------------------------------------------------------------------------------


def bound_for(a: np.ndarray) -> float:
    """The max error of the GOP and motion tables: 1 % of the range (at least 1)."""
    return max(1.0, round(0.01 * value_range(a)))


def part_gops(anims, quick):
    rows = []
    for name, a in anims.items():
        settings = [("quality", 255), ("quality", 15), ("max_error", bound_for(a))]
        for what, v in settings:
            for g in GOPS:
                r = run_volpack(a, gop_string=g, **{what: v})
                log(f"gops {name} {g} {what}={v}: ratio {r['ratio']:.2f} PSNR {r['psnr']:.2f}")
                rows.append({"animation": name, "setting": f"{what}={v}", "gop": g, **r})
    return rows


def part_wavelets(anims, quick):
    rows = []
    for name in ("head-subvoxel", "advect", "fmri"):
        if name not in anims:
            continue
        for w in WAVELETS:
            r = run_volpack(anims[name], gop_string="IBBPBBPBB", quality=255, wavelet=w)
            log(f"wavelets {name} {w}: ratio {r['ratio']:.2f}")
            rows.append({"animation": name, "wavelet": w, **r})
    return rows


CODER_CONFIGS = {
    "arith": {"coder": "arith"},
    "huffman": {"coder": "huffman"},
    "huffman, B without residual": {"coder": "huffman", "b_residual": False},
}


def part_coders(quick):
    from volpack import synth

    n = 64 if quick else 128
    a = synth.advect((n, n, n), 9)
    rows = []
    for label, cfg in CODER_CONFIGS.items():
        for q in QUALITIES[::2] if quick else QUALITIES:
            r = run_volpack(a, decodes=2, gop_string="IBBPBBPBB", quality=q, wavelet="26", **cfg)
            log(f"coders {label} q{q}: ratio {r['ratio']:.2f} {r['decode_fps']:.1f} fps (CPU)")
            rows.append({"animation": f"advect-{n}", "coder": label, "quality": q, **r})
    return rows


SPEED_CONFIGS = {
    "quarter/half, windowed": {},
    "half, windowed": {"precision": "half"},
    "half, block": {"precision": "half", "compensation": "block"},
}


def part_speed(quick):
    """Decode speed of a bounded animation at 128^3 (the issue's 10 frames/s goal)."""
    from volpack import synth

    n = 64 if quick else 128
    a = synth.advect((n, n, n), 9)
    rows = []
    for label, cfg in SPEED_CONFIGS.items():
        r = run_volpack(a, decodes=2, gop_string="IBBPBBPBB", max_error=2, **cfg)
        log(f"speed {label}: ratio {r['ratio']:.2f} {r['decode_fps']:.1f} fps (CPU)")
        rows.append({"animation": f"advect-{n}", "motion": label, "bound": 2, **r})
    return rows


def part_peers(anims, quick):
    rows = []
    ps = peers()
    for name in ("head-subvoxel", "head-halfvoxel", "advect", "fmri"):
        if name not in anims:
            continue
        a = anims[name]
        rng = value_range(a)
        bounds = sorted({max(1.0, round(f * rng)) for f in (0.005, 0.01, 0.02, 0.04)})
        if quick:
            bounds = bounds[1:3]
        for e in bounds:
            for label, kw in (("volpack IBBPBBPBB", "IBBPBBPBB"), ("volpack I", "I")):
                r = run_volpack(a, gop_string=kw, max_error=e)
                rows.append({"animation": name, "method": label, "bound": e, **r})
            for pname, m in ps.items():
                rows.append({"animation": name, "method": f"{pname} per frame", "bound": e,
                             **run_peer(m, a, e)})  # fmt: skip
            if "sz3" in ps:
                rows.append({"animation": name, "method": "sz3 4-D", "bound": e,
                             **run_peer(ps["sz3"], a, e, whole=True)})  # fmt: skip
            for r in rows[-(3 + len(ps)) :]:
                log(f"peers {name} E={e} {r['method']}: ratio {r['ratio']:.2f} "
                    f"max err {r['max_error']:.3g} PSNR {r['psnr']:.2f}")  # fmt: skip
    return rows


def part_motion(anims, quick):
    from volpack import synth

    rows = []
    for name in ("head-subvoxel", "head-halfvoxel", "advect"):
        a = anims[name]
        e = bound_for(a)
        for prec in ("whole", "half", "quarter"):
            for comp in ("windowed", "block"):
                r = run_volpack(a, gop_string="IBBPBBPBB", max_error=e, precision=prec,
                                compensation=comp)  # fmt: skip
                rows.append({"animation": name, "bound": e, "precision": prec,
                             "compensation": comp, "search": "fast", **r})  # fmt: skip
                log(f"motion {name} {prec} {comp}: ratio {r['ratio']:.2f}")
    small = synth.translate(synth.head((32, 32, 32)), 5, step=(1.0, -2.0, 0.5))
    for search in ("fast", "exhaustive"):
        r = run_volpack(small, gop_string="IPPPP", max_error=2, method=search)
        rows.append({"animation": "head32-move", "bound": 2, "precision": "half",
                     "compensation": "windowed", "search": search, **r})  # fmt: skip
        log(f"motion search {search}: ratio {r['ratio']:.2f} encode {r['encode_s']:.1f}s")
    return rows


TOOL_CONFIGS = {
    "default": {},
    "no whole-frame shifts": {"whole_frame": False},
    "I-frames at E": {"i_max_error": "E"},
    "neither": {"whole_frame": False, "i_max_error": "E"},
}


def part_tools(anims, quick):
    """Each tool of the moving heads switched off in turn, against I-only."""
    rows = []
    for name in ("head-subvoxel", "head-halfvoxel"):
        a = anims[name]
        for e in (2, 4) if quick else (1, 2, 4, 9):
            alone = run_volpack(a, gop_string="I", max_error=e)
            rows.append({"animation": name, "bound": e, "tools": "I-only", **alone})
            for label, cfg in TOOL_CONFIGS.items():
                kw = {k: (e if v == "E" else v) for k, v in cfg.items()}
                r = run_volpack(a, gop_string="IBBPBBPBB", max_error=e, **kw)
                r["x_i_only"] = r["ratio"] / alone["ratio"]
                rows.append({"animation": name, "bound": e, "tools": label, **r})
                log(f"tools {name} E={e} {label}: ratio {r['ratio']:.2f} "
                    f"({r['x_i_only']:.2f}x I-only)")  # fmt: skip
    return rows


# -- output ---------------------------------------------------------------------------


def write_csv(rows, path: Path) -> None:
    if not rows:
        return
    keys = list(rows[0])
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=keys, extrasaction="ignore")
        w.writeheader()
        for r in rows:
            w.writerow({k: _fmt(r.get(k)) for k in keys})


def _fmt(v):
    if isinstance(v, list):
        return ";".join(_fmt(x) for x in v)
    if isinstance(v, float):
        return "inf" if math.isinf(v) else f"{v:.6g}"
    return "" if v is None else v


def _f(v, digits=2):
    if v is None:
        return "-"
    if isinstance(v, float) and math.isinf(v):
        return "inf"
    return f"{v:.{digits}f}"


def equal_psnr(rows, method, target):
    """Ratio of ``method`` at ``target`` dB, interpolated (log ratio linear in PSNR)."""
    pts = sorted((r["psnr"], r["ratio"]) for r in rows if r["method"] == method)
    pts = [p for p in pts if math.isfinite(p[0])]
    for (p0, r0), (p1, r1) in zip(pts, pts[1:]):
        if p0 <= target <= p1 and p1 > p0:
            f = (target - p0) / (p1 - p0)
            return math.exp(math.log(r0) + f * (math.log(r1) - math.log(r0)))
    return None


def write_table(parts, out: Path, args) -> None:
    lines = [
        "# Animation benchmark",
        "",
        f"`python scripts/bench_animation.py{' --quick' if args.quick else ''}`",
        "",
    ]
    gops = parts.get("gops", [])
    if gops:
        lines += [
            "## GOPs (Table 2.11)",
            "",
            "| animation | setting | GOP | ratio | PSNR | max error | PSNR I / P / B | frame types |",
            "|---|---|---|---:|---:|---:|---|---|",
        ]
        for r in gops:
            lines.append(
                f"| {r['animation']} | {r['setting']} | {r['gop']} | {_f(r['ratio'])} | {_f(r['psnr'])} | {r['max_error']:g} | {_f(r['psnr_I'])} / {_f(r['psnr_P'])} / {_f(r['psnr_B'])} | {r['types']} |"
            )
        lines.append("")
    wav = parts.get("wavelets", [])
    if wav:
        lines += [
            "## Wavelets at quality 255, IBBPBBPBB (Table 2.9)",
            "",
            "| animation | wavelet | PSNR I | PSNR P | PSNR B | ratio |",
            "|---|---|---:|---:|---:|---:|",
        ]
        for r in wav:
            lines.append(
                f"| {r['animation']} | {r['wavelet']} | {_f(r['psnr_I'])} | {_f(r['psnr_P'])} | {_f(r['psnr_B'])} | {_f(r['ratio'])} |"
            )
        lines.append("")
    cod = parts.get("coders", [])
    if cod:
        labels = list(dict.fromkeys(r["coder"] for r in cod))
        lines += ["## Quality and coder, IBBPBBPBB, 2/6 wavelet, decode frames/s of one thread's CPU time (Table 2.10)", "",
                  "| animation | quality | " + " | ".join(f"{c} ratio | {c} fps | {c} PSNR" for c in labels) + " |",
                  "|---|---:|" + "---:|---:|---:|" * len(labels)]  # fmt: skip
        by = {(r["coder"], r["quality"]): r for r in cod}
        for q in sorted({r["quality"] for r in cod}, reverse=True):
            cells = []
            for c in labels:
                r = by.get((c, q))
                cells += [_f(r["ratio"]), _f(r["decode_fps"], 1), _f(r["psnr"])] if r else ["-"] * 3
            lines.append(f"| {cod[0]['animation']} | {q} | " + " | ".join(cells) + " |")
        lines.append("")
    prs = parts.get("peers", [])
    if prs:
        lines += [
            "## Peers at equal max error",
            "",
            "| animation | E | method | ratio | max error | PSNR | decode fps (CPU) |",
            "|---|---:|---|---:|---:|---:|---:|",
        ]
        for r in prs:
            lines.append(
                f"| {r['animation']} | {r['bound']:g} | {r['method']} | {_f(r['ratio'])} | {r['max_error']:.3g} | {_f(r['psnr'])} | {_f(r['decode_fps'], 1)} |"
            )
        lines += [
            "",
            "## Peers at equal PSNR (interpolated from the sweep above)",
            "",
            "| animation | PSNR | " + " | ".join(sorted({r["method"] for r in prs})) + " |",
            "|---|---:|" + "---:|" * len({r["method"] for r in prs}),
        ]
        for name in dict.fromkeys(r["animation"] for r in prs):
            sub = [r for r in prs if r["animation"] == name]
            ps = sorted(
                r["psnr"]
                for r in sub
                if r["method"] == "volpack IBBPBBPBB" and math.isfinite(r["psnr"])
            )
            for target in ps:
                t = round(target, 1)
                cells = [_f(equal_psnr(sub, m, t)) for m in sorted({r["method"] for r in prs})]
                lines.append(f"| {name} | {t} | " + " | ".join(cells) + " |")
        lines.append("")
    spd = parts.get("speed", [])
    if spd:
        lines += [
            "## Decode speed with a max error, IBBPBBPBB (frames/s of one thread's CPU time)",
            "",
            "| animation | E | motion | ratio | PSNR | decode fps (CPU) | decode fps (wall) |",
            "|---|---:|---|---:|---:|---:|---:|",
        ]
        for r in spd:
            wall = len(r["types"]) / r["decode_wall_s"]
            lines.append(
                f"| {r['animation']} | {r['bound']:g} | {r['motion']} | {_f(r['ratio'])} | {_f(r['psnr'])} | {_f(r['decode_fps'], 1)} | {_f(wall, 1)} |"
            )
        lines.append("")
    mot = parts.get("motion", [])
    if mot:
        lines += [
            "## Motion settings, IBBPBBPBB at one max error",
            "",
            "| animation | E | precision | compensation | search | ratio | PSNR | encode s | motion bytes |",
            "|---|---:|---|---|---|---:|---:|---:|---:|",
        ]
        for r in mot:
            lines.append(
                f"| {r['animation']} | {r['bound']:g} | {r['precision']} | {r['compensation']} | {r['search']} | {_f(r['ratio'])} | {_f(r['psnr'])} | {_f(r['encode_s'], 1)} | {r['motion_bytes']} |"
            )
        lines.append("")
    tools = parts.get("tools", [])
    if tools:
        lines += [
            "## Tools on the moving heads, IBBPBBPBB against I-only at equal max error",
            "",
            "| animation | E | tools | ratio | x I-only | PSNR | max error | encode s | decode fps (CPU) |",
            "|---|---:|---|---:|---:|---:|---:|---:|---:|",
        ]
        for r in tools:
            lines.append(
                f"| {r['animation']} | {r['bound']:g} | {r['tools']} | {_f(r['ratio'])} | {_f(r.get('x_i_only'))} | {_f(r['psnr'])} | {r['max_error']:g} | {_f(r['encode_s'], 1)} | {_f(r['decode_fps'], 1)} |"
            )
        lines.append("")
    (out / "table.md").write_text("\n".join(lines))


def write_charts(parts, out: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    gops = [r for r in parts.get("gops", []) if r["animation"] == "head-subvoxel"]
    if gops:
        fig, axes = plt.subplots(1, 2, figsize=(11, 4))
        for ax, setting in zip(
            axes, sorted({r["setting"] for r in gops if r["setting"] != "quality=15"})
        ):
            for r in gops:
                if r["setting"] == setting:
                    ps = [min(p, 80) for p in r["frame_psnr"]]
                    ax.plot(
                        range(len(ps)), ps, marker="o", label=f"{r['gop']} ({r['ratio']:.1f}:1)"
                    )
            ax.set_title(f"head-subvoxel, {setting}")
            ax.set_xlabel("frame")
            ax.set_ylabel("PSNR (dB)")
            ax.legend(fontsize=8)
        fig.tight_layout()
        fig.savefig(out / "psnr_per_frame.png", dpi=110)
        plt.close(fig)
    prs = parts.get("peers", [])
    names = list(dict.fromkeys(r["animation"] for r in prs))
    if prs:
        fig, axes = plt.subplots(1, len(names), figsize=(4.5 * len(names), 4), squeeze=False)
        for ax, name in zip(axes[0], names):
            sub = [r for r in prs if r["animation"] == name]
            for m in dict.fromkeys(r["method"] for r in sub):
                pts = sorted(
                    (r["psnr"], r["ratio"])
                    for r in sub
                    if r["method"] == m and math.isfinite(r["psnr"])
                )
                if pts:
                    ax.plot([p for p, _ in pts], [q for _, q in pts], marker="o", label=m)
            ax.set_yscale("log")
            ax.set_title(name)
            ax.set_xlabel("PSNR (dB)")
            ax.set_ylabel("ratio")
            ax.legend(fontsize=7)
        fig.tight_layout()
        fig.savefig(out / "ratio_vs_psnr.png", dpi=110)
        plt.close(fig)


PARTS = ("gops", "wavelets", "coders", "speed", "peers", "motion", "tools")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="smaller animations, fewer settings")
    ap.add_argument("--parts", default=",".join(PARTS), help=f"comma list of {PARTS}")
    ap.add_argument("--out", default=None, help="output folder (default results/animation)")
    args = ap.parse_args(argv)
    out = (
        Path(args.out)
        if args.out
        else ROOT / "results" / "animation" / ("quick" if args.quick else "")
    )
    out.mkdir(parents=True, exist_ok=True)
    anims = animations(args.quick)
    want = args.parts.split(",")
    parts = {}
    runners = {
        "gops": lambda: part_gops(anims, args.quick),
        "wavelets": lambda: part_wavelets(anims, args.quick),
        "coders": lambda: part_coders(args.quick),
        "speed": lambda: part_speed(args.quick),
        "peers": lambda: part_peers(anims, args.quick),
        "motion": lambda: part_motion(anims, args.quick),
        "tools": lambda: part_tools(anims, args.quick),
    }
    for p in PARTS:
        if p in want:
            t0 = time.perf_counter()
            parts[p] = runners[p]()
            write_csv(parts[p], out / f"{p}.csv")
            log(f"{p}: {time.perf_counter() - t0:.0f} s")
    write_table(parts, out, args)
    write_charts(parts, out)
    log(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
