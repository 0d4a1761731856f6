"""Lossy coding of 2-D fields and thin stacks: volpack against SZ3 and SPERR (point-wise),
every bound checked on every voxel for every codec, one process.

Arrays: every float field of scripts/datasets.py as its middle slice (1, y, x) and as a
4-slice slab from the middle (fields of fewer than 4 slices: skipped); real 2-D fields of
Debian's libncarg-data (unpacked with dpkg -x into NCARG, default /tmp/f34deb/root; name
the file and variable); two seeded Gaussian random fields (synthetic, labelled "grf").
Bounds 1e-2..1e-5 of the value range. Per cell: bytes, ratio, x best of SZ3/SPERR,
decode MB/s of the second decode (input MB over CPU seconds), and which set it is in.

Held out (decided before any tuning): the slices and slabs of cam_v, eta_v, storm_u,
tgv_u, sea_ice, mri_inia19_float; the real 2-D HSURF and tas EUR11; the grf of slope -4.

Run: PYTHONPATH=. python results/lossy/flat34/trial.py OUT.csv [NAMES]
"""

from __future__ import annotations

import csv
import os
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "scripts"))

from datasets import load, names  # noqa: E402

from volpack import api, peers  # noqa: E402

BOUNDS = (1e-2, 1e-3, 1e-4, 1e-5)
NCARG = Path(os.environ.get("NCARG", "/tmp/f34deb/root/usr/share/ncarg/data"))
REAL_2D = (  # (label, file, variable): unmasked 2-D float fields >= 256x256
    ("trinidad_topo", "cdf/trinidad.nc", "data"),
    ("orog_mod3", "nug/orog_mod3_rectilinear_grid_2D.nc", "orog"),
    ("sftlf_mod3", "nug/sftlf_mod3_rectilinear_grid_2D.nc", "sftlf"),
    ("hsurf_0.11deg", "nug/HSURF_regional_model_0.11deg.nc", "HSURF"),
    ("tas_eur11", "nug/tas_rotated_grid_EUR11.nc", "tas"),
)
HELD_FIELDS = ("cam_v", "eta_v", "storm_u", "tgv_u", "sea_ice", "mri_inia19_float")
HELD_OTHER = ("hsurf_0.11deg", "tas_eur11", "grf_s4_768x512")


def grf(shape: tuple[int, int], slope: float, seed: int) -> np.ndarray:
    """A Gaussian random field with power spectrum |k|^slope (synthetic)."""
    rng = np.random.default_rng(seed)
    ky = np.fft.fftfreq(shape[0])[:, None]
    kx = np.fft.rfftfreq(shape[1])[None, :]
    k = np.hypot(ky, kx)
    k[0, 0] = 1.0
    amp = k ** (slope / 2)
    amp[0, 0] = 0.0
    noise = rng.standard_normal((shape[0], kx.size)) + 1j * rng.standard_normal((shape[0], kx.size))
    f = np.fft.irfft2(noise * amp, s=shape)
    return (f / f.std()).astype(np.float32)


def arrays(only: set[str] | None):
    for name in names(kinds=("float",)):
        v = np.asarray(load(name)[0], dtype=np.float32)
        mid = v.shape[0] // 2
        held = name in HELD_FIELDS
        yield f"{name}/slice", v[mid : mid + 1], held
        if v.shape[0] >= 4:
            yield f"{name}/slab4", v[mid - 2 : mid + 2], held
    import netCDF4

    for label, file, var in REAL_2D:
        a = np.squeeze(np.asarray(netCDF4.Dataset(NCARG / file).variables[var][:], np.float32))
        yield f"{label}/2d", a[None], label in HELD_OTHER
    yield "grf_s3_1024/2d", grf((1024, 1024), -3.0, 0)[None], False
    yield "grf_s4_768x512/2d", grf((768, 512), -4.0, 1)[None], True


def timed_decode(decode, blob):
    decode(blob)
    t = time.process_time()
    out = decode(blob)
    return out, time.process_time() - t


def cell(a: np.ndarray, rel: float, workers: int = 1) -> dict:
    span = float(a.max()) - float(a.min())
    e = rel * span
    mb = a.nbytes / 1e6
    t = time.process_time()
    blob = api.compress_array(a, rel_error=rel, workers=workers)
    enc = time.process_time() - t
    back, dec = timed_decode(lambda b: api.decompress_array(b, workers=1), blob)
    err = float(np.abs(back.astype(np.float64) - a.astype(np.float64)).max())
    assert err <= e, ("volpack", rel, err, e)
    row = {"bytes": len(blob), "ratio": round(a.nbytes / len(blob), 3),
           "enc_cpu": round(enc, 3), "dec_mb_s": round(mb / max(dec, 1e-9), 1)}  # fmt: skip
    found, _ = peers.bounded(a.dtype, a.shape, e)
    best = None
    for p in found:
        if p.name not in ("sz3", "sperr"):
            continue
        pb = p.encode(a)
        pback, pdec = timed_decode(p.decode, pb)
        perr = float(np.abs(np.asarray(pback, np.float64).reshape(a.shape) - a).max())
        ok = perr <= e
        n = peers.nbytes(pb)
        row[f"{p.name}_bytes"] = n
        row[f"{p.name}_ok"] = ok
        row[f"{p.name}_dec_mb_s"] = round(mb / max(pdec, 1e-9), 1)
        if ok and (best is None or n < best[1]):
            best = (p.name, n)
    if best:
        row["best_peer"] = best[0]
        row["x_best"] = round(best[1] / len(blob), 4)
    return row


def main(out: str, only: set[str] | None) -> None:
    rows = []
    warm = np.linspace(0, 1, 4096, dtype=np.float32).reshape(1, 64, 64)
    for rel in BOUNDS:
        cell(warm, rel)  # compile first
    for label, a, held in arrays(only):
        if only and label.split("/")[0] not in only:
            continue
        a = np.ascontiguousarray(a)
        for rel in BOUNDS:
            row = {"array": label, "shape": "x".join(map(str, a.shape)),
                   "set": "held-out" if held else "tuned", "rel": rel, **cell(a, rel)}  # fmt: skip
            print(row, flush=True)
            rows.append(row)
    keys = list(dict.fromkeys(k for r in rows for k in r))
    with open(out, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=keys)
        w.writeheader()
        w.writerows(rows)


if __name__ == "__main__":
    main(sys.argv[1], set(sys.argv[2].split(",")) if len(sys.argv) > 2 else None)
