"""Animations of real float fields with fill values: volpack's animation coding against
the same frames coded one by one as 3-D volumes, and against zstd.

    python scripts/bench_animation_fields.py            # every series (a few minutes)
    python scripts/bench_animation_fields.py --quick    # fewer frames

Series (float32, (t, z, y, x)):

* ``storm_t``    NCL's ``Tstorm.cdf`` (Debian libncarg-data): temperature of a storm, 64
  time steps of 33 x 36, fill -9999 on 20 % of the voxels (a mask that moves)
* ``contour_z``  NCL's ``contour.cdf``: geopotential height, 7 times of 10 levels x
  33 x 36, fill -9999 (a mask that changes with time)
* ``sea_ice``    NCL's ``fice.nc``: sea-ice concentration, 120 months x 49 x 100 (no
  fill values present; the first 24 months)
* ``tas_monthly`` NCL's ``tas_rectilinear_grid_2D.nc``: 12 months x 96 x 192
* ``tgv_u``      the Taylor-Green vortex (``simulate.py``, Re 1600, 64^3), x velocity at
  t = 5.3 .. 6.0 every 0.1 (8 frames; computed once and cached)

Per series and mode (lossless; and ``max_error`` = 1e-3 of the valid range): the ratio
(raw bytes / file bytes), PSNR and max error over the valid voxels, encode and decode
MB/s of raw data, for the animation (GOP IPPPPPPP, fill value given), the animation of I-frames only
(``animation-I``: special voxels taken out, no prediction), the 4-D array compressed as
a volume (``volume-4d``: each frame coded alone as a 3-D volume, one file, as
``volpack compress`` without ``--gop``; fill value given) and zstd -19 of the raw array. Special voxels are checked bit for bit and the bound on every other voxel.
Writes ``results/animation/fields.csv`` and ``fields.png``.
"""

from __future__ import annotations

import argparse
import io
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import datasets  # noqa: E402
from bench_animation import write_csv  # noqa: E402

GOP = "IPPPPPPP"
OUT = Path(__file__).resolve().parents[1] / "results" / "animation"


def _netcdf(name: str, frames: int | None):
    from scipy.io import netcdf_file

    ds = datasets.DATASETS[name]
    with netcdf_file(datasets.path_of(name), "r", mmap=False) as f:
        v = f.variables[ds.variable]
        a = np.array(v.data, dtype=np.float32)
        fill = None
        for key in ("_FillValue", "missing_value"):
            if key in v._attributes:
                fill = float(np.asarray(v._attributes[key]).ravel()[0])
    a = a[:frames] if frames else a
    if a.ndim == 3:
        a = a[:, None]
    if fill is not None and not (a == np.float32(fill)).any():
        fill = None  # declared but absent
    return np.ascontiguousarray(a), fill


def _tgv(frames: int):
    cache = Path("/tmp") / "volpack_tgv_u_series.npy"
    if cache.is_file():
        return np.load(cache)[:frames], None
    from simulate import taylor_green_series

    times = [round(5.3 + 0.1 * i, 1) for i in range(8)]
    a = np.stack([f["u"] for f in taylor_green_series(times=times)])
    np.save(cache, a)
    return a[:frames], None


def series(quick: bool) -> dict[str, tuple[np.ndarray, float | None]]:
    n = 4 if quick else None
    return {
        "storm_t": _netcdf("storm_t", 16 if quick else None),
        "contour_z": _netcdf("contour_z", n),
        "sea_ice": _netcdf("sea_ice", 8 if quick else 24),
        "tas_monthly": _netcdf("tas_monthly", n),
        "tgv_u": _tgv(4 if quick else 8),
    }


def _special(a, fill):
    m = ~np.isfinite(a)
    return m | (a == np.float32(fill)) if fill is not None else m


def _quality(a, out, fill, e):
    """(max error, PSNR) over the valid voxels; specials checked bit for bit."""
    sp = _special(a, fill)
    assert np.array_equal(out[sp].view(np.uint32), a[sp].view(np.uint32)), "specials changed"
    d = np.abs(out[~sp].astype(np.float64) - a[~sp])
    m = float(d.max(initial=0.0))
    assert m <= (e or 0.0), f"error {m} past the bound {e}"
    if e is None:
        assert np.array_equal(out.view(np.uint32), a.view(np.uint32)), "not bit-exact"
    v = a[~sp].astype(np.float64)
    peak = float(v.max() - v.min()) if v.size else 0.0
    mse = float(np.mean(d * d)) if d.size else 0.0
    psnr = float("inf") if mse == 0 else 10 * np.log10(peak * peak / mse)
    return m, psnr


def run_animation(a, fill, e, gop=GOP):
    from volpack.animation import stream as animation

    buf = io.BytesIO()
    t0 = time.perf_counter()
    animation.compress(a, buf, gop_string=gop, max_error=e, fill_value=fill)
    enc = time.perf_counter() - t0
    t0 = time.perf_counter()
    out = animation.decompress(buf.getvalue()).data
    return len(buf.getvalue()), enc, time.perf_counter() - t0, out


def run_frames(a, fill, e):
    """The 4-D array as a volume: every frame coded alone as a 3-D volume (bricks within
    a frame), all in one file, as ``volpack compress`` does without ``--gop``."""
    import volpack

    buf = io.BytesIO()
    t0 = time.perf_counter()
    volpack.compress(a, buf, max_error=e, fill_value=fill if e is not None else None)
    enc = time.perf_counter() - t0
    t0 = time.perf_counter()
    out = volpack.decompress(buf.getvalue()).data
    return len(buf.getvalue()), enc, time.perf_counter() - t0, out


def run_zstd(a, fill, e):
    import zstandard

    raw = a.tobytes()
    t0 = time.perf_counter()
    blob = zstandard.ZstdCompressor(level=19).compress(raw)
    enc = time.perf_counter() - t0
    t0 = time.perf_counter()
    out = np.frombuffer(zstandard.ZstdDecompressor().decompress(blob), a.dtype).reshape(a.shape)
    return len(blob), enc, time.perf_counter() - t0, out


def run_i_only(a, fill, e):
    return run_animation(a, fill, e, "I")


METHODS = {
    "animation": run_animation,
    "animation-I": run_i_only,
    "volume-4d": run_frames,
    "zstd-19": run_zstd,
}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--quick", action="store_true")
    args = p.parse_args(argv)
    from volpack import synth

    warm = synth.advect((8, 12, 12), 4, dtype=np.float32)
    warm[:, :2] = -1.0
    for e in (None, 0.01):  # compile the kernels before timing
        run_animation(warm, -1.0, e)
        run_frames(warm, -1.0, e)
    rows = []
    for name, (a, fill) in series(args.quick).items():
        sp = _special(a, fill)
        valid = a[~sp]
        rel = 1e-3 * float(valid.max() - valid.min())
        for mode, e in (("lossless", None), ("max_error", rel)):
            for method, run in METHODS.items():
                if method == "zstd-19" and e is not None:
                    continue
                size, enc, dec, out = run(a, fill, e)
                m, psnr = _quality(a, out, fill, e)
                mb = a.nbytes / 1e6
                rows.append({
                    "series": name, "shape": "x".join(map(str, a.shape)),
                    "special_pct": round(100 * sp.mean(), 1), "mode": mode,
                    "bound": e, "method": method, "ratio": round(a.nbytes / size, 3),
                    "max_error": m, "psnr": round(psnr, 2),
                    "enc_mb_s": round(mb / enc, 2), "dec_mb_s": round(mb / dec, 2),
                })  # fmt: skip
                print(rows[-1], flush=True)
    OUT.mkdir(parents=True, exist_ok=True)
    write_csv(rows, OUT / "fields.csv")
    _chart(rows, OUT / "fields.png")
    return 0


def _chart(rows, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = list(dict.fromkeys(r["series"] for r in rows))
    fig, axes = plt.subplots(1, 2, figsize=(11, 4))
    for ax, mode in zip(axes, ("lossless", "max_error")):
        methods = [m for m in METHODS if any(r["method"] == m and r["mode"] == mode for r in rows)]
        w = 0.8 / len(methods)
        for i, m in enumerate(methods):
            v = [next((r["ratio"] for r in rows if (r["series"], r["mode"], r["method"]) ==
                       (n, mode, m)), 0) for n in names]  # fmt: skip
            ax.bar(np.arange(len(names)) + i * w, v, w, label=m)
        ax.set_xticks(np.arange(len(names)) + 0.4 - w / 2, names, rotation=20)
        ax.set_ylabel("ratio")
        ax.set_title("lossless" if mode == "lossless" else "max error 1e-3 of the range")
        ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=110)


if __name__ == "__main__":
    sys.exit(main())
