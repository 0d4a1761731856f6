"""ldec31's corpus: load a field (tgv128 made here) and the default-effort streams,
encoded once and cached under $LDEC31_BLOBS (default /tmp/ldec31/blobs)."""

import os
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "scripts"))
from datasets import load  # noqa: E402

TUNE = ["climate_t", "hgt_500", "ct_skull_float", "sst_monthly", "tgv128"]
HELDOUT = ["cam_u", "eta_v", "mecca_t", "seam_ps", "xray_1jzv", "md_water"]
RELS = (1e-2, 1e-3, 1e-4, 1e-5)
BLOBS = Path(os.environ.get("LDEC31_BLOBS", "/tmp/ldec31/blobs"))


def field(name: str) -> np.ndarray:
    if name == "tgv128":
        from scipy import ndimage

        a = load("tgv_vorticity")[0].astype(np.float32)
        return ndimage.zoom(a, [128 / s for s in a.shape], order=1, output=np.float32)
    return np.ascontiguousarray(load(name)[0])


def bound(a: np.ndarray, rel: float) -> float:
    return rel * (float(a.max()) - float(a.min()))


def blob(name: str, rel: float, a: np.ndarray | None = None) -> bytes:
    """The default-effort stream of the cell (made by whatever volpack is imported)."""
    p = BLOBS / f"{name}_{rel:g}.vpk"
    if p.exists():
        return p.read_bytes()
    from volpack import api

    a = field(name) if a is None else a
    b = bytes(api.compress_array(a, max_error=bound(a, rel)))
    BLOBS.mkdir(parents=True, exist_ok=True)
    p.write_bytes(b)
    return b


if __name__ == "__main__":
    import time

    names = sys.argv[1:] or TUNE + HELDOUT
    for n in names:
        a = field(n)
        for r in RELS:
            t = time.time()
            b = blob(n, r, a)
            print(n, r, len(b), f"{a.nbytes / len(b):.2f}", f"{time.time() - t:.1f}s", flush=True)
