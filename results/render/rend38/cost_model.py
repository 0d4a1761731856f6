"""A cost model of the fast march's opaque frames (session 38, rend38; issue 22): the same
view rendered with empty-space maps that change how many segments, empty-space tests and
jumps a frame takes (4^3 and 2^3 bricks; ``v1``: every visible brick tested again where
the ray leaves it, not where it leaves the cube of visible bricks around it; ``e2``: only
empty bricks at Chebyshev distance >= 2 from a visible one jumped), each frame's CPU
(best of ROUNDS, variants interleaved) and its counts (``cost.patch``: segments in
bits 0-19 of a row's count, tests in 20-41, jumps from 42), then a least
squares fit ``cpu = fixed + c_seg segments + c_test tests + c_jump jumps``. The images of
all variants are the same (checked). Run with the patch applied, then revert it:

    git apply results/render/rend38/cost.patch
    PYTHONPATH=. python results/render/rend38/cost_model.py VOLUME ... [--shadings none]
    git checkout volpack/render/raycast.py
"""

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "scripts"))
sys.path.insert(0, str(ROOT / "results" / "render" / "rend37"))
import bench_render_peers as peers  # noqa: E402
from probe import load  # noqa: E402

from volpack.render import raycast  # noqa: E402
from volpack.render.camera import Camera  # noqa: E402
from volpack.render.prepared import prepare_volume  # noqa: E402
from volpack.render.transfer import TransferFunction  # noqa: E402

ROUNDS = 5
VARIANTS = ("4", "4v1", "4e2", "2", "2v1", "2e2")
_LEAP = raycast._leap_kernel
_FINISH = raycast.finish_render
CAP = {}


def leap_of(key):
    def run(empty, out):
        _LEAP(empty, out)
        if "e2" in key:
            _LEAP(np.ascontiguousarray(out >= 2), out)
        if "v1" in key:
            out[out < 0] = -1

    return run


def setting(key):
    raycast.FINE_BRICK = int(key[0])
    raycast._leap_kernel = leap_of(key)


def finish(out, rows, t0, st):
    CAP["rows"] = rows.copy()
    return _FINISH(out, rows, t0, st)


def counts():
    r = CAP["rows"]
    return (
        int((r & ((1 << 20) - 1)).sum()),
        int(((r >> 20) & ((1 << 22) - 1)).sum()),
        int((r >> 42).sum()),
    )


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("volumes", nargs="+")
    ap.add_argument("--shadings", nargs="+", default=["none", "phong"])
    a = ap.parse_args()
    raycast.finish_render = finish
    for name in a.volumes:
        vol, sp = load(name)
        tf = TransferFunction(points=peers.tf_points("opaque", *peers.tf_base(vol)))
        cam = Camera(azimuth=30.0, elevation=peers.ELEVATION, size=(512, 512))
        for sh in a.shadings:
            preps = {k: prepare_volume(vol, sp) for k in VARIANTS}
            res = {}
            for k in VARIANTS:
                setting(k)
                img = raycast.render(preps[k], tf=tf, camera=cam, step=0.5, shading=sh, workers=2)
                res[k] = [img, counts(), []]
            for _ in range(ROUNDS):
                for k in VARIANTS:
                    setting(k)
                    c = time.process_time()
                    raycast.render(preps[k], tf=tf, camera=cam, step=0.5, shading=sh, workers=2)
                    res[k][2].append(time.process_time() - c)
            setting("4")
            x = np.array([[1.0, *res[k][1]] for k in VARIANTS])
            y = np.array([min(res[k][2]) for k in VARIANTS])
            coef, *_ = np.linalg.lstsq(x, y, rcond=None)
            vname = Path(name).name.split(".")[0]
            for k in VARIANTS:
                seg, tests, jumps = res[k][1]
                same = np.array_equal(res[k][0], res["4"][0])
                fit = float(x[VARIANTS.index(k)] @ coef)
                print(
                    f"{vname:12s} {sh:5s} {k:4s} cpu {1e3 * min(res[k][2]):6.1f} ms (fit "
                    f"{1e3 * fit:6.1f})  segments {seg / 1e6:5.2f} M  tests {tests / 1e6:5.2f} M  "
                    f"jumps {jumps / 1e6:5.2f} M  same image {same}",
                    flush=True,
                )
            f, cs, ct, cj = coef
            s4, t4, j4 = res["4"][1]
            print(
                f"{vname:12s} {sh:5s} fit: fixed {1e3 * f:5.1f} ms, {1e9 * cs:5.1f} ns a segment, "
                f"{1e9 * ct:5.1f} ns a test, {1e9 * cj:5.1f} ns a jump; at 4^3 bricks: segments "
                f"{1e3 * cs * s4:5.1f} ms, tests {1e3 * ct * t4:5.1f} ms, jumps {1e3 * cj * j4:5.1f} ms",
                flush=True,
            )


if __name__ == "__main__":
    main()
