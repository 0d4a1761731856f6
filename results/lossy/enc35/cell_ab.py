"""One field's default lossy encode, the old ``_normal`` (tests/naive.py's Python stack)
against the new one swapped in turn in ONE process, a warm-up, then best of N CPU
times of each, and whether they wrote the same bytes: a check of the bench_lossy_ab
cells that came out below 1.

    PYTHONPATH=. python results/lossy/enc35/cell_ab.py FIELD REL [N]
"""

from __future__ import annotations

import hashlib
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[3]
sys.path[:0] = [str(ROOT / "tests"), str(ROOT / "scripts")]
import datasets  # noqa: E402
import naive  # noqa: E402

from volpack import api  # noqa: E402
from volpack.volume_codec import bounded_longfit as lf  # noqa: E402


def main():
    name, rel = sys.argv[1], float(sys.argv[2])
    rounds = int(sys.argv[3]) if len(sys.argv) > 3 else 5
    a = np.ascontiguousarray(datasets.load(name)[0])
    e = rel * (float(a.max()) - float(a.min()))
    impl = {"old": naive.longfit_normal, "new": lf._normal}
    best, digest = {}, {}
    for r in range(rounds + 1):
        for k in ("old", "new") if r % 2 else ("new", "old"):
            lf._normal = impl[k]
            t0 = time.process_time()
            out = api.compress_array(a, max_error=e)
            dt = time.process_time() - t0
            h = hashlib.sha256(out).hexdigest()
            assert digest.setdefault(k, h) == h
            if r:
                best[k] = min(best.get(k, dt), dt)
    lf._normal = impl["new"]
    print(f"| {name} | {rel:g} | {best['old']:.3f} | {best['new']:.3f} | "
          f"{best['old'] / best['new']:.3f} | {digest['old'] == digest['new']} |")


if __name__ == "__main__":
    main()
