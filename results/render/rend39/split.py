"""Where the opaque frames' fixed part goes (session 39, rend39; issue 22).

    PYTHONPATH=. python results/render/rend39/split.py VOLUME ... > results/render/rend39/split.txt

At the peers benchmark's first view (azimuth 30, 512^2, step 0.5, opaque TF), one
thread (CPU = wall), best of ROUNDS, interleaved:
  frame      the whole frame (unshaded, then Phong)
  refine=1   the same without refinement (what refinement costs: the difference)
  clear TF   the same camera with a TF of zero opacity: every ray's set-up up to its
             first empty-space test, which ends it
  set-up     a kernel of the march's per-ray set-up alone (pixel_ray, _ray_span, the
             fixed-point base and strides, the first empty-space test, ``interior`` on
             three axes) over the rays the march traces; also its count of rays by fate
  interior   the same set-up kernel without the three ``interior`` calls
"""

import sys
import time
from pathlib import Path

import numba
import numpy as np

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "scripts"))
sys.path.insert(0, str(ROOT / "results" / "render" / "rend37"))
import bench_render_peers as peers  # noqa: E402
from probe import load  # noqa: E402

from volpack.render import raycast as rc  # noqa: E402
from volpack.render.camera import Camera, pixel_ray  # noqa: E402
from volpack.render.fixed import interior, to_fixed  # noqa: E402
from volpack.render.prepared import prepare_volume  # noqa: E402
from volpack.render.transfer import TransferFunction  # noqa: E402

ROUNDS = 5


@numba.njit(nogil=True)
def setup_only(frame, u, v, row_cols, nz, ny, nx, vscale, step, leap, brick, sh, with_interior):
    fates = np.zeros(4, np.int64)  # miss box, leave at first test, marched, sum of klo-khi
    for r in range(row_cols.shape[0]):
        for c in range(row_cols[r, 0], row_cols[r, 1]):
            oz, oy, ox, dz, dy, dx = pixel_ray(frame, u, v, r, c)
            tnear, tfar, nseg, vz, vy, vx = rc._ray_span(
                oz, oy, ox, dz, dy, dx, nz, ny, nx, vscale, step
            )
            if nseg == 0:
                fates[0] += 1
                continue
            bz, by, bx = (
                to_fixed(oz + tnear * dz),
                to_fixed(oy + tnear * dy),
                to_fixed(ox + tnear * dx),
            )
            sz, sy, sx = to_fixed(step * dz), to_fixed(step * dy), to_fixed(step * dx)
            iz, iy, ix = 1.0 / sz, 1.0 / sy, 1.0 / sx
            state, i, next_k = rc._leap_fixed(
                0, nseg, bz, by, bx, sz, sy, sx, iz, iy, ix, nz, ny, nx, leap, brick, sh
            )
            if state == 2:
                fates[1] += 1
                continue
            fates[2] += 1
            if with_interior:
                klo_z, khi_z = interior(bz, sz, nz)
                klo_y, khi_y = interior(by, sy, ny)
                klo_x, khi_x = interior(bx, sx, nx)
                fates[3] += min(khi_z, khi_y, khi_x) - max(klo_z, klo_y, klo_x) + next_k + i
            else:
                fates[3] += next_k + i
    return fates


def best_cpu(fn, rounds=ROUNDS):
    ts = []
    for _ in range(rounds):
        c = time.process_time()
        fn()
        ts.append(time.process_time() - c)
    return min(ts) * 1e3


def main(names):
    for name in names:
        vol, sp = load(name)
        prep = prepare_volume(vol, sp)
        base = peers.tf_base(vol)
        tf = TransferFunction(points=peers.tf_points("opaque", *base))
        pts = np.array(peers.tf_points("opaque", *base), np.float64)
        pts[:, 4] = 0.0  # zero opacity
        clear_tf = TransferFunction(points=[tuple(p) for p in pts])
        cam = Camera(azimuth=30.0, elevation=peers.ELEVATION, size=(512, 512))
        kw = dict(camera=cam, step=0.5, workers=1)
        runs = {
            "frame none": lambda prep=prep, tf=tf, kw=kw: rc.render(
                prep, tf=tf, shading="none", **kw
            ),
            "refine=1 none": lambda prep=prep, tf=tf, kw=kw: rc.render(
                prep, tf=tf, shading="none", refine=1, **kw
            ),
            "frame phong": lambda prep=prep, tf=tf, kw=kw: rc.render(
                prep, tf=tf, shading="phong", **kw
            ),
            "refine=1 phong": lambda prep=prep, tf=tf, kw=kw: rc.render(
                prep, tf=tf, shading="phong", refine=1, **kw
            ),
            "clear TF": lambda prep=prep, kw=kw, clear_tf=clear_tf: rc.render(
                prep, tf=clear_tf, shading="none", **kw
            ),
        }
        stats = {}
        for k in runs:  # compile, and the segment counts
            sh = "phong" if "phong" in k else "none"
            ref = 1 if "refine=1" in k else rc.REFINE
            t = clear_tf if k == "clear TF" else tf
            _, st = rc.render(prep, tf=t, shading=sh, refine=ref, render_stats=True, **kw)
            stats[k] = st
        # the leap map and the traced columns as the frame has them
        shape = vol.shape
        ray_grid = cam.ray_grid(shape, sp)
        row_cols = np.zeros((512, 3), np.int64)
        row_cols[:, :2] = cam.box_columns(shape, sp)
        leap = prep_leap(prep, vol, sp, tf)
        vscale = np.array([s / min(sp) for s in sp], np.float64)
        brick = rc.FINE_BRICK
        shb = int(np.log2(brick))
        nz, ny, nx = shape
        for wi in (True, False):
            setup_only(*ray_grid, row_cols, nz, ny, nx, vscale, 0.5, leap, brick, shb, wi)
        times = {k: [] for k in list(runs) + ["set-up", "set-up w/o interior"]}
        for _ in range(ROUNDS):
            for k, f in runs.items():
                c = time.process_time()
                f()
                times[k].append(time.process_time() - c)
            for k, wi in (("set-up", True), ("set-up w/o interior", False)):
                c = time.process_time()
                fates = setup_only(
                    *ray_grid, row_cols, nz, ny, nx, vscale, 0.5, leap, brick, shb, wi
                )
                times[k].append(time.process_time() - c)
        nm = Path(name).stem.split(".")[0]
        traced = int((row_cols[:, 1] - row_cols[:, 0]).clip(0).sum())
        print(
            f"{nm}: rays traced {traced}, miss box {fates[0]}, end at first test "
            f"{fates[1]}, marched {fates[2]}"
        )
        for k, ts in times.items():
            seg = f"  segments {stats[k].samples / 1e6:.2f} M" if k in stats else ""
            print(f"  {k:22s} cpu {min(ts) * 1e3:7.1f} ms{seg}")
        sys.stdout.flush()


def prep_leap(prep, vol, sp, tf):
    """The leap map the frame used: captured from the render by wrapping the march."""
    cap = {}
    orig, orig_m = rc._NEAR_MARCH, dict(rc._MARCH)

    def wrap(f):
        def spy(*a):
            cap["leap"] = a[15]
            return f(*a)

        return spy

    rc._NEAR_MARCH = wrap(orig)
    rc._MARCH.update({k: wrap(f) for k, f in orig_m.items()})
    try:
        rc.render(
            prep,
            tf=tf,
            camera=Camera(azimuth=30.0, elevation=peers.ELEVATION, size=(512, 512)),
            step=0.5,
            workers=1,
        )
    finally:
        rc._NEAR_MARCH = orig
        rc._MARCH.update(orig_m)
    return cap["leap"]


if __name__ == "__main__":
    main(sys.argv[1:])
