"""volpack's ray caster against VTK's CPU ray caster at equal settings and equal quality.

Peer: ``vtkFixedPointVolumeRayCastMapper`` (VTK's CPU ray caster: 15-bit fixed point,
per-voxel quantised normals, space leaping, early ray termination), headless through
EGL, ``pip install vtk``. For each volume x transfer function x shading:

* the same array (its own dtype and spacing), the same control points (colour and
  opacity, opacity per smallest spacing: VTK's ``ScalarOpacityUnitDistance``), the same
  orthographic view and image size, the same number of threads (``--workers``);
* VTK **matched**: ``AutoAdjustSampleDistances`` off, ``SampleDistance`` = the step in
  world units (``--step`` times the smallest spacing), ``ImageSampleDistance`` 1;
  VTK **default**: its defaults (auto-adjusted sampling);
* volpack ``preintegrated`` (its default) and ``post`` (classification as VTK's) at
  the same step, and ``preintegrated`` at ``--coarse-step`` (1 voxel): the same
  quality in fewer samples is what pre-integration is for;
* the first image (everything built from scratch: VTK's gradient tables, volpack's
  :func:`~volpack.render.prepared.prepare_volume` and tables) and then ``--frames``
  further orbit views 10 degrees apart (volpack re-renders the prepared volume; VTK
  re-renders its mapper), timed as wall seconds and process CPU seconds, the
  renderers taking turns frame by frame so machine load hits them alike (VTK's first
  image also opens its offscreen window: each case builds a new scene);
* each renderer's first image scored by PSNR (RGB on black) against its own render of
  the same view at a fine step (``--ref-step``, 0.125 voxel); VTK's default is scored
  against VTK's fine reference.

Volumes: ``ct_head`` (int16 CT, 108 x 256 x 256, anisotropic), ``mri_mni152`` (uint8
MRI, 189 x 233 x 197), ``zmap_neurovault`` (float32 z-map, 46 x 63 x 53). Transfer
functions over the range from the median voxel to the maximum: ``semi`` (clear below
10 % of it, opacity 0.02 at 40 %, 0.15 at the top) and ``opaque`` (clear below 30 %,
0.9 at 45 %, 1 at the top). Writes
``peers.csv`` and ``peers.png`` (time per frame against PSNR) under ``--out``.

    python scripts/bench_render_peers.py [--quick] [--out results/render] [--workers 2]
        [--volumes ct_head ...] [--tfs semi opaque]
"""

from __future__ import annotations

import argparse
import csv
import math
import os
import statistics
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "scripts"))
os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")

KA, KD, KS, SHIN = 0.25, 0.75, 0.35, 24.0
VOLUMES = ("ct_head", "mri_mni152", "zmap_neurovault")
ELEVATION = 20.0


def tf_points(kind: str, lo: float, hi: float) -> tuple:
    """Control points over ``[lo, hi]`` (``lo``: the median voxel, see :func:`tf_base`)."""
    r = hi - lo
    if kind == "semi":
        return ((lo + 0.1 * r, 0.0, 0.0, 0.0, 0.0), (lo + 0.4 * r, 0.9, 0.6, 0.5, 0.02),
                (hi, 1.0, 1.0, 1.0, 0.15))  # fmt: skip
    return ((lo + 0.3 * r, 0.0, 0.0, 0.0, 0.0), (lo + 0.45 * r, 0.9, 0.75, 0.6, 0.9),
            (hi, 1.0, 1.0, 1.0, 1.0))  # fmt: skip


def tf_base(vol: np.ndarray) -> tuple[float, float]:
    """The range the TFs span: the median voxel (the background of a z-map or an MRI,
    so the TFs show what stands out of it) to the maximum."""
    hi = float(np.nanmax(vol))
    lo = float(np.nanmedian(vol))
    return (lo, hi) if lo < hi else (float(np.nanmin(vol)), hi)


def view_frame(shape, spacing, azimuth):
    """volpack's orthographic framing in world (x, y, z): centre, eye direction, scale."""
    from volpack.render.camera import MARGIN

    sp = np.array(spacing, float)
    shp = np.array(shape, float)
    centre_zyx = (shp - 1) / 2 * sp
    radius = 0.5 * float(np.linalg.norm(shp * sp)) * MARGIN
    az, el = math.radians(azimuth), math.radians(ELEVATION)
    fwd_xyz = np.array([math.sin(az) * math.cos(el), math.cos(az) * math.cos(el), -math.sin(el)])
    return centre_zyx[::-1], fwd_xyz, radius


class Vtk:
    """One VTK scene; :meth:`frame` renders one view and returns (wall s, cpu s)."""

    def __init__(self, vol, spacing, points, shade, workers, size, sample_distance):
        import vtk
        from vtk.util import numpy_support as ns

        nz, ny, nx = vol.shape
        img = vtk.vtkImageData()
        img.SetDimensions(nx, ny, nz)
        img.SetSpacing(spacing[2], spacing[1], spacing[0])
        img.GetPointData().SetScalars(ns.numpy_to_vtk(np.ascontiguousarray(vol).ravel(), deep=True))
        ctf = vtk.vtkColorTransferFunction()
        otf = vtk.vtkPiecewiseFunction()
        for v, r, g, b, a in points:
            ctf.AddRGBPoint(v, r, g, b)
            otf.AddPoint(v, a)
        prop = vtk.vtkVolumeProperty()
        prop.SetColor(ctf)
        prop.SetScalarOpacity(otf)
        prop.SetScalarOpacityUnitDistance(min(spacing))  # opacity per smallest spacing
        prop.SetInterpolationTypeToLinear()
        if shade:
            prop.ShadeOn()
            prop.SetAmbient(KA)
            prop.SetDiffuse(KD)
            prop.SetSpecular(KS)
            prop.SetSpecularPower(SHIN)
        mapper = vtk.vtkFixedPointVolumeRayCastMapper()
        mapper.SetInputData(img)
        if sample_distance is not None:  # matched; None keeps VTK's defaults
            mapper.SetAutoAdjustSampleDistances(0)
            mapper.SetSampleDistance(sample_distance)
            mapper.SetImageSampleDistance(1.0)
        mapper.SetNumberOfThreads(workers)
        actor = vtk.vtkVolume()
        actor.SetMapper(mapper)
        actor.SetProperty(prop)
        ren = vtk.vtkRenderer()
        ren.AddVolume(actor)
        ren.SetBackground(0, 0, 0)
        win = vtk.vtkRenderWindow()
        win.SetOffScreenRendering(1)
        win.AddRenderer(ren)
        win.SetSize(size, size)
        cam = ren.GetActiveCamera()
        cam.ParallelProjectionOn()
        self.vtk, self.win, self.ren, self.cam = vtk, win, ren, cam
        self.shape, self.spacing, self.size = vol.shape, spacing, size

    def frame(self, azimuth: float):
        centre, fwd, radius = view_frame(self.shape, self.spacing, azimuth)
        self.cam.SetFocalPoint(*centre)
        self.cam.SetPosition(*(centre - 4 * radius * fwd))
        self.cam.SetViewUp(0, 0, 1)
        self.cam.SetParallelScale(radius)
        self.ren.ResetCameraClippingRange()
        t, c = time.perf_counter(), time.process_time()
        self.win.Render()
        return time.perf_counter() - t, time.process_time() - c

    def image(self) -> np.ndarray:
        from vtk.util import numpy_support as ns

        w2i = self.vtk.vtkWindowToImageFilter()
        w2i.SetInput(self.win)
        w2i.ReadFrontBufferOff()
        w2i.Update()
        arr = ns.vtk_to_numpy(w2i.GetOutput().GetPointData().GetScalars())
        return arr.reshape(self.size, self.size, -1)[::-1, :, :3].astype(np.float32) / 255


class Volpack:
    """volpack with the same scene; the first frame starts from the raw array."""

    def __init__(self, vol, spacing, points, shade, workers, size, step, classification):
        from volpack.render.transfer import TransferFunction

        self.vol, self.spacing, self.size, self.step = vol, spacing, size, step
        self.tf = TransferFunction(points=points)
        self.kw = dict(classification=classification, shading="phong" if shade else "none",
                       workers=workers)  # fmt: skip
        self.prep = None
        self.img = None

    def frame(self, azimuth: float, step=None):
        from volpack.render.camera import Camera
        from volpack.render import raycast
        from volpack.render.prepared import prepare_volume
        from volpack.render.raycast import render

        cam = Camera(azimuth=azimuth, elevation=ELEVATION, size=(self.size, self.size))
        if self.prep is None:  # the first image builds its tables too, not another's
            raycast._TABLES.clear()
        n0 = COMPILES[0]
        t, c = time.perf_counter(), time.process_time()
        if self.prep is None:
            self.prep = prepare_volume(self.vol, self.spacing)
        img = render(self.prep, tf=self.tf, camera=cam, step=step or self.step, **self.kw)
        dt, dc = time.perf_counter() - t, time.process_time() - c
        if COMPILES[0] != n0:  # warm_up missed a kernel: the time would count the compiler
            print(f"  warning: {COMPILES[0] - n0} kernel(s) compiled inside a timed frame",
                  flush=True)  # fmt: skip
        self.img = img
        return dt, dc

    def image(self) -> np.ndarray:
        return self.img[..., :3]


def psnr(img: np.ndarray, ref: np.ndarray) -> float:
    mse = float(np.mean((img.astype(np.float64) - ref) ** 2))
    return 99.0 if mse == 0 else 10 * math.log10(1.0 / mse)


def run_case(name, vol, spacing, tfk, shade, args, rows):
    points = tf_points(tfk, *tf_base(vol))
    make = {
        "vtk-matched": lambda s: Vtk(vol, spacing, points, shade, args.workers, args.size,
                                     s * min(spacing)),  # fmt: skip
        "vtk-default": lambda s: Vtk(vol, spacing, points, shade, args.workers, args.size, None),
        "volpack-preint": lambda s: Volpack(vol, spacing, points, shade, args.workers,
                                            args.size, s, "preintegrated"),  # fmt: skip
        "volpack-post": lambda s: Volpack(vol, spacing, points, shade, args.workers,
                                          args.size, s, "post"),  # fmt: skip
    }
    rens = {k: f(args.step) for k, f in make.items()}
    # pre-integration at a coarser step, scored against the same fine reference
    rens["volpack-preint-coarse"] = make["volpack-preint"](args.coarse_step)
    angles = [30.0 + 10.0 * k for k in range(args.frames + 1)]
    times = {k: [] for k in rens}
    images = {}
    for j, az in enumerate(angles):  # turn by turn, so load hits all alike
        for k, r in rens.items():
            times[k].append(r.frame(az))
            if j == 0:
                images[k] = r.image()
    refs = {}
    for fam, k in (("vtk", "vtk-matched"), ("volpack-preint", "volpack-preint"),
                   ("volpack-post", "volpack-post")):  # fmt: skip
        rr = make[k](args.ref_step)
        rr.frame(angles[0])
        refs[fam] = rr.image()
    for k, ts in times.items():
        ref = refs["vtk" if k.startswith("vtk") else k.replace("-coarse", "")]
        later = ts[1:]
        row = {
            "volume": name, "dtype": str(vol.dtype), "tf": tfk,
            "shading": "phong" if shade else "none", "renderer": k,
            "step_world": "auto" if k == "vtk-default" else round(
                (args.coarse_step if k.endswith("coarse") else args.step) * min(spacing), 4),
            "first_s": round(ts[0][0], 4),
            "first_cpu_s": round(ts[0][1], 4),
            "frame_s": round(statistics.median(t for t, _ in later), 4),
            "frame_cpu_s": round(statistics.median(c for _, c in later), 4),
            "psnr_db": round(psnr(images[k], ref), 2),
        }  # fmt: skip
        rows.append(row)
    vt = next(r for r in rows[-len(rens):] if r["renderer"] == "vtk-matched")
    for r in rows[-len(rens):]:
        r["vs_vtk_matched"] = round(r["frame_s"] / vt["frame_s"], 2)
        print(f"  {name:16s} {tfk:6s} {r['shading']:5s} {r['renderer']:15s} first "
              f"{r['first_s']:6.3f} s (cpu {r['first_cpu_s']:6.3f})  frame {r['frame_s']:6.3f} s (cpu {r['frame_cpu_s']:6.3f})"
              f"  x{r['vs_vtk_matched']:5.2f} of VTK matched  PSNR {r['psnr_db']:5.1f} dB"
              f"  step {r['step_world']}",
              flush=True)  # fmt: skip


def chart(rows, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    colours = {"vtk-matched": "tab:blue", "vtk-default": "tab:cyan",
               "volpack-preint": "tab:red", "volpack-post": "tab:orange",
               "volpack-preint-coarse": "tab:purple"}  # fmt: skip
    markers = {v: m for v, m in zip(VOLUMES, "o^s")}
    fig, ax = plt.subplots(figsize=(7.5, 5))
    for r in rows:
        ax.scatter(r["frame_s"], r["psnr_db"], c=colours[r["renderer"]],
                   marker=markers.get(r["volume"], "x"),
                   edgecolors="k" if r["shading"] == "phong" else "none", s=40)  # fmt: skip
    for k, c in colours.items():
        ax.scatter([], [], c=c, label=k)
    for v, m in markers.items():
        ax.scatter([], [], c="grey", marker=m, label=v)
    ax.set_xscale("log")
    ax.set_xlabel("seconds per frame (median of later frames; black edge: shaded)")
    ax.set_ylabel("PSNR against the renderer's own step-0.125 image (dB)")
    ax.set_title("Ray casting: volpack vs VTK fixed-point, same TF, view, threads")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="lower right")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def scene_args(doc: str) -> argparse.ArgumentParser:
    """A parser with the options the render benchmarks share (output, threads, image
    size, step, volumes)."""
    ap = argparse.ArgumentParser(description=doc.splitlines()[0])
    ap.add_argument("--out", type=Path, default=ROOT / "results" / "render")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--size", type=int, default=512)
    ap.add_argument("--step", type=float, default=0.5)
    ap.add_argument("--volumes", nargs="+", default=list(VOLUMES))
    return ap


def main(argv=None) -> int:
    ap = scene_args(__doc__)
    ap.add_argument("--ref-step", type=float, default=0.125)
    ap.add_argument("--coarse-step", type=float, default=1.0,
                    help="step of the extra pre-integrated volpack run")  # fmt: skip
    ap.add_argument("--frames", type=int, default=3, help="further frames after the first")
    ap.add_argument("--quick", action="store_true", help="256^2 images, 2 further frames")
    ap.add_argument("--tfs", nargs="+", default=["semi", "opaque"], choices=["semi", "opaque"],
                    help="the transfer functions to run")  # fmt: skip
    args = ap.parse_args(argv)
    if args.quick:
        args.size, args.frames = 256, 2
    args.out.mkdir(parents=True, exist_ok=True)
    count_compiles()
    rows: list[dict] = []
    for name in args.volumes:
        vol, spacing = load_warm(name, args.workers)
        print(f"{name} {vol.shape} {vol.dtype} spacing {spacing}", flush=True)
        for tfk in args.tfs:
            for shade in (False, True):
                run_case(name, vol, spacing, tfk, shade, args, rows)
    with open(args.out / "peers.csv", "w", newline="") as f:
        wr = csv.DictWriter(f, fieldnames=list(rows[0]))
        wr.writeheader()
        wr.writerows(rows)
    chart(rows, args.out / "peers.png")
    print(f"wrote {args.out / 'peers.csv'} and peers.png")
    return 0


COMPILES = [0]  # numba compilations seen (a kernel loaded from the disk cache is not one)


def count_compiles() -> None:
    """Count numba's compilations in :data:`COMPILES`, to check that none happens inside
    a timed frame."""
    from numba.core import event

    class Counter(event.Listener):
        def on_start(self, ev):
            COMPILES[0] += 1

        def on_end(self, ev):
            pass

    event.register("numba:compile", Counter())


def load_warm(name: str, workers: int):
    """Dataset ``name`` (or a volume file volpack reads, e.g. ``field.npy``) as ``(array,
    spacing as floats)``, volpack's kernels warmed up on it (:func:`warm_up`)."""
    if Path(name).is_file():
        from volpack.api import read_volume

        v = read_volume(name)
        vol, spacing = v.data, v.spacing
    else:
        import datasets

        vol, spacing, _ = datasets.load(name)
    spacing = tuple(float(s) for s in spacing)
    warm_up(vol, spacing, workers)
    return vol, spacing


def warm_up(vol, spacing, workers: int) -> None:
    """Compile volpack's kernels outside the timings (VTK's code is compiled already):
    ``volpack warmup``'s renders (:func:`volpack.warmup.warm_render`: a sample of each
    dtype the ray caster samples, every classification and shading), then a coarse copy
    of the volume with the cases' TFs on ``workers`` threads. The coarse copy alone (this
    function before session 28) left a kernel to compile inside a timed frame on an empty
    cache (``results/warmup/user28/``)."""
    from volpack.render.camera import Camera
    from volpack.render.raycast import render
    from volpack.render.transfer import TransferFunction
    from volpack.warmup import warm_render

    warm_render()
    k = max(1, max(vol.shape) // 16)
    small = vol[::k, ::k, ::k]
    sp_small = tuple(s * k for s in spacing)
    for tfk in ("semi", "opaque"):
        tf = TransferFunction(points=tf_points(tfk, *tf_base(vol)))
        for cls in ("preintegrated", "post"):
            for sh in ("none", "phong"):
                render(small, spacing=sp_small, tf=tf, classification=cls, shading=sh,
                       camera=Camera(size=(16, 16)), workers=workers)  # fmt: skip


if __name__ == "__main__":
    raise SystemExit(main())
