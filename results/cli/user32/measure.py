"""The fixes' before and after, in one process, interleaved, best of N by CPU time; every
stream decoded and compared bit for bit. GROUP:

* long: 64-bit integers; before = byte-shuffled zstd, which `auto` chose for them up to
  a8c186a (codec='zstd' with auto's brick);
* channels: (z, y, x, c) volumes; before = channels_last=False (the 4-D array taken as
  (t, z, y, x), as a8c186a did, with its interleave decision);
* masks: bool volumes; before = zstd, as for `long`.

With BASE (a folder holding a8c186a's volpack/), the base's own default stream is also
made in a subprocess and its length recorded (base_bytes: it must equal before_bytes).

    PYTHONPATH=. python results/cli/user32/measure.py GROUP VOLDIR OUT.csv [N [BASE]]

VOLDIR holds make.py's volumes; the held-out ones are made here (seeds and sources not
used while the change was written).
"""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[3] / "scripts"))
sys.path.insert(0, str(Path(__file__).resolve().parent))
from datasets import load  # noqa: E402
from make import blobs, voronoi_labels  # noqa: E402
from run import write  # noqa: E402
from scipy import ndimage  # noqa: E402

from volpack import api  # noqa: E402
from volpack.volume_codec.bricks import default_brick  # noqa: E402


def base_bytes(base: str, a: np.ndarray, tmp: Path) -> int:
    np.save(tmp, a)
    code = "import sys, numpy as np, volpack; print(len(volpack.compress_array(np.load(sys.argv[1]))))"
    env = {**os.environ, "PYTHONPATH": base}
    out = subprocess.run([sys.executable, "-c", code, str(tmp)], env=env, check=True,
                         capture_output=True, text=True, cwd=base)
    tmp.unlink()
    return int(out.stdout.split()[-1])


def long_ints(voldir):
    """make.py's seg_u64 and aal_u64, then volumes of the same kind made after the
    change: another segmentation (denser, ids below 2^40, another seed and shape), a real
    label atlas as int64 ids, and real scans as numpy's default int64."""
    rng = np.random.default_rng(2032)
    out = {k: np.load(voldir / f"{k}.npy") for k in ("seg_u64", "aal_u64")}
    out["seg2_u64"] = voronoi_labels((64, 192, 192), 12000, rng, np.uint64, 2**40)
    lab, _, _ = load("frog_labels")
    ids = np.random.default_rng(11).choice(2**31, size=int(lab.max()) + 1, replace=False)
    out["frog_i64"] = ids.astype(np.int64)[lab]
    ct, _, _ = load("ct_head")
    out["ct_i64"] = ct.astype(np.int64)
    mri, _, _ = load("mri_ch2")
    out["ch2_i64"] = mri.astype(np.int64)
    return out


def channels(voldir):
    """make.py's colour-mapped MRI and two-channel stack, then held-out ones: the MNI
    template's T1, grey- and white-matter maps as three channels (real), and another
    two-channel fluorescence stack (another seed and shape)."""
    out = {k: np.load(voldir / f"{k}.npy") for k in ("ch2_rgb_zyxc", "fluo2_zyxc")}
    maps = [load(k)[0] for k in ("mri_mni152", "mni152_gm", "mni152_wm")]
    out["mni_t1gmwm_zyxc"] = np.stack(maps, -1)
    rng = np.random.default_rng(4032)
    nuc = blobs((32, 256, 256), 500, 3.0, rng)
    cyto = ndimage.gaussian_filter(blobs((32, 256, 256), 200, 6.0, rng), 2.0)
    two = np.stack([rng.poisson(nuc * 2000 + 100), rng.poisson(cyto / cyto.max() * 700 + 90)], -1)
    out["fluo2b_zyxc"] = two.astype(np.uint16)
    return out


def masks(voldir):
    """make.py's brain mask, then held-out masks of real segmentations (foreground of
    the CGAL liver labels, the frog's tissues, the AAL atlas)."""
    out = {"mask_bool": np.load(voldir / "mask_bool.npy")}
    for k in ("liver_labels", "frog_labels", "atlas_aal"):
        out[f"{k}_mask"] = load(k)[0] > 0
    return out


GROUPS = {
    "long": (long_ints, lambda a: {"codec": "zstd", "brick": default_brick(a.shape, a.dtype, False, "auto")}),
    "channels": (channels, lambda a: {"channels_last": False}),
    "masks": (masks, lambda a: {"codec": "zstd", "brick": default_brick(a.shape, a.dtype, False, "auto")}),
}


def cpu(f, n):
    best, res = None, None
    for _ in range(n):
        t = time.process_time()
        res = f()
        dt = time.process_time() - t
        best = dt if best is None else min(best, dt)
    return best, res


def main(group: str, voldir: Path, out_csv: Path, n: int, base: str | None) -> None:
    make, before = GROUPS[group]
    vols = make(voldir)
    for a in vols.values():  # the kernels compiled before anything is timed
        api.compress_array(np.ascontiguousarray(a[:8, :16, :16]))
    rows = []
    for name, a in vols.items():
        row = {"volume": name, "dtype": str(a.dtype), "shape": "x".join(map(str, a.shape)),
               "raw_mb": round(a.nbytes / 1e6, 2)}
        enc = {"before": [], "after": []}
        blobs = {}
        for _ in range(n):  # interleaved
            for tag, opts in (("before", before(a)), ("after", {})):
                t, blob = cpu(lambda a=a, o=opts: api.compress_array(a, **o), 1)
                enc[tag].append(t)
                blobs[tag] = blob
        for tag in ("before", "after"):
            blob = blobs[tag]
            dt, back = cpu(lambda b=blob: api.decompress_array(b), n)
            assert back.dtype == a.dtype and back.tobytes() == a.tobytes(), (name, tag)
            row[f"{tag}_bytes"] = len(blob)
            row[f"{tag}_ratio"] = round(a.nbytes / len(blob), 3)
            row[f"{tag}_enc_cpu_s"] = round(min(enc[tag]), 3)
            row[f"{tag}_dec_cpu_s"] = round(dt, 3)
        row["gain"] = round(row["before_bytes"] / row["after_bytes"], 3)
        if base:
            row["base_bytes"] = base_bytes(base, a, Path(base) / f"{name}.tmp.npy")
        if a.dtype.itemsize == 8 and int(a.min()) >= 0 and int(a.max()) < 2**32:
            u32 = a.astype(np.uint32)
            row["as_uint32_ratio"] = round(a.nbytes / len(api.compress_array(u32)), 3)
        print(row, flush=True)
        rows.append(row)
        write(rows, out_csv)


if __name__ == "__main__":
    args = sys.argv[1:]
    n = int(args[3]) if len(args) > 3 else 2
    main(args[0], Path(args[1]), Path(args[2]), n, args[4] if len(args) > 4 else None)
