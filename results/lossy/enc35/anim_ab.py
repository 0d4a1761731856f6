"""The 4-frame animation encode (``--gop IPPP --max-error 0.05`` of a drifting xray_1jzv
series, as prof_encode.py builds it), old ``_normal`` (tests/naive.py's Python stack)
against the new one, in ONE process, rounds interleaved, best CPU time of each, and
whether the two wrote the same bytes.

    PYTHONPATH=. python results/lossy/enc35/anim_ab.py [rounds] > results/lossy/enc35/anim_ab.md
"""

from __future__ import annotations

import hashlib
import io
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "tests"))
sys.path.insert(0, str(Path(__file__).resolve().parent))
import naive  # noqa: E402
from prof_encode import drifting  # noqa: E402

from volpack.animation import stream as animation  # noqa: E402
from volpack.volume_codec import bounded_longfit as lf  # noqa: E402


def main():
    rounds = int(sys.argv[1]) if len(sys.argv) > 1 else 3
    s = drifting()
    impl = {"old": naive.longfit_normal, "new": lf._normal}
    best, digest = {}, {}
    for r in range(rounds + 1):  # round 0: warm-up, not timed
        for name in (("old", "new") if r % 2 else ("new", "old")):
            lf._normal = impl[name]
            buf = io.BytesIO()
            t0 = time.process_time()
            animation.compress(s, buf, gop_string="IPPP", max_error=0.05)
            dt = time.process_time() - t0
            digest.setdefault(name, hashlib.sha256(buf.getvalue()).hexdigest())
            assert digest[name] == hashlib.sha256(buf.getvalue()).hexdigest()
            if r:
                best[name] = min(best.get(name, dt), dt)
    lf._normal = impl["new"]
    print(f"4-frame IPPP animation of a drifting xray_1jzv ({tuple(s.shape)} float32, "
          f"max error 0.05), best of {rounds} CPU s")
    print()
    print("| old _normal s | new _normal s | speedup | bytes | same_bytes |")
    print("|---:|---:|---:|---:|:---:|")
    print(f"| {best['old']:.2f} | {best['new']:.2f} | {best['old'] / best['new']:.2f} "
          f"| {len(buf.getvalue())} | {digest['old'] == digest['new']} |")


if __name__ == "__main__":
    main()
