"""volpack's ray caster against VTK's CPU ray caster, same data, view, TF and threads.

Peer: ``vtkFixedPointVolumeRayCastMapper`` (VTK's CPU ray caster: 15-bit fixed point,
pre-computed gradient normals, space leaping, early ray termination), headless through
EGL, ``pip install vtk``. Both render the head CT resampled to 256^3 (linear along z from
108 x 256 x 256, isotropic unit spacing) into a 512 x 512 image, orthographic, azimuth 30,
elevation 20, with the ``ct-bone`` preset (semi-transparent), sample distance 0.5 voxel,
unshaded and shaded (ambient 0.25, diffuse 0.75, specular 0.35, power 24), on the same
number of threads (``--workers``, default 2: VTK's multithreader and volpack's row sets).

For each renderer: the first image (VTK builds its gradient tables there; volpack builds
its TF tables and brick ranges on every call) and the median of ``--repeat`` re-renders
(orbit steps of 10 degrees, so neither renders the same view twice). volpack runs post,
pre-integrated, and pre-integrated with centroid shading. The ratio is VTK's time over
volpack's (above 1: volpack is faster). Both images are saved for a visual check; their
pixels are not compared (the renderers differ in opacity units and colour blending).

    python scripts/bench_render_peers.py [--out results/render] [--repeat 5] [--workers 2]
"""

from __future__ import annotations

import argparse
import csv
import os
import statistics
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "scripts"))
os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")

SIZE = 512
STEP = 0.5
KA, KD, KS, SHIN = 0.25, 0.75, 0.35, 24.0


def ct256() -> np.ndarray:
    import datasets

    a, _, _ = datasets.load("ct_head")
    a = a.astype(np.float32)
    zi = np.linspace(0, a.shape[0] - 1, 256)
    z0 = np.floor(zi).astype(int)
    z1 = np.minimum(z0 + 1, a.shape[0] - 1)
    f = (zi - z0)[:, None, None]
    return np.ascontiguousarray(a[z0] * (1 - f) + a[z1] * f, dtype=np.float32)


class VtkRenderer:
    """The same scene in VTK; ``render(azimuth)`` returns seconds for one image."""

    def __init__(self, vol: np.ndarray, tf, lo: float, hi: float, shade: bool, workers: int):
        import vtk
        from vtk.util import numpy_support as ns

        # unsigned short keeps VTK on its fast fixed-point path; the TF is mapped alike
        self.offset = lo
        u16 = np.round(vol - lo).astype(np.uint16)
        img = vtk.vtkImageData()
        nz, ny, nx = vol.shape
        img.SetDimensions(nx, ny, nz)
        img.GetPointData().SetScalars(ns.numpy_to_vtk(u16.ravel(), deep=True))
        table = tf.table(lo, hi, 256)
        values = np.linspace(0, hi - lo, 256)
        ctf = vtk.vtkColorTransferFunction()
        otf = vtk.vtkPiecewiseFunction()
        for v, (r, g, b, a) in zip(values, table):
            ctf.AddRGBPoint(float(v), float(r), float(g), float(b))
            otf.AddPoint(float(v), float(a))
        prop = vtk.vtkVolumeProperty()
        prop.SetColor(ctf)
        prop.SetScalarOpacity(otf)
        prop.SetScalarOpacityUnitDistance(1.0)  # opacity per voxel, as in volpack
        prop.SetInterpolationTypeToLinear()
        if shade:
            prop.ShadeOn()
            prop.SetAmbient(KA)
            prop.SetDiffuse(KD)
            prop.SetSpecular(KS)
            prop.SetSpecularPower(SHIN)
        mapper = vtk.vtkFixedPointVolumeRayCastMapper()
        mapper.SetInputData(img)
        mapper.SetSampleDistance(STEP)
        mapper.SetAutoAdjustSampleDistances(0)
        mapper.SetNumberOfThreads(workers)
        volume = vtk.vtkVolume()
        volume.SetMapper(mapper)
        volume.SetProperty(prop)
        ren = vtk.vtkRenderer()
        ren.AddVolume(volume)
        ren.SetBackground(0, 0, 0)
        win = vtk.vtkRenderWindow()
        win.SetOffScreenRendering(1)
        win.AddRenderer(ren)
        win.SetSize(SIZE, SIZE)
        cam = ren.GetActiveCamera()
        cam.ParallelProjectionOn()
        centre = [(n - 1) / 2 for n in (nx, ny, nz)]
        cam.SetFocalPoint(*centre)
        cam.SetViewUp(0, 0, 1)
        self.vtk, self.win, self.ren, self.cam, self.centre = vtk, win, ren, cam, centre
        self.radius = 0.5 * float(np.linalg.norm(vol.shape)) * 1.05

    def place(self, azimuth: float, elevation: float) -> None:
        import math

        az, el = math.radians(azimuth), math.radians(elevation)
        # volpack's convention: azimuth 0 looks along +y, elevation lifts the eye above
        fwd = np.array([math.sin(az) * math.cos(el), math.cos(az) * math.cos(el), -math.sin(el)])
        eye = np.array(self.centre) - 4 * self.radius * fwd
        self.cam.SetPosition(*eye)
        self.cam.SetFocalPoint(*self.centre)
        self.cam.SetViewUp(0, 0, 1)
        self.cam.SetParallelScale(self.radius)
        self.ren.ResetCameraClippingRange()

    def render(self, azimuth: float, elevation: float) -> float:
        self.place(azimuth, elevation)
        t = time.perf_counter()
        self.win.Render()
        return time.perf_counter() - t

    def image(self) -> np.ndarray:
        from vtk.util import numpy_support as ns

        w2i = self.vtk.vtkWindowToImageFilter()
        w2i.SetInput(self.win)
        w2i.ReadFrontBufferOff()
        w2i.Update()
        arr = ns.vtk_to_numpy(w2i.GetOutput().GetPointData().GetScalars())
        return arr.reshape(SIZE, SIZE, -1)[::-1, :, :3]


def main(argv=None) -> int:
    from volpack.render.camera import Camera
    from volpack.render.image import save_png
    from volpack.render.raycast import render
    from volpack.render.transfer import preset

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=ROOT / "results" / "render")
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--workers", type=int, default=2)
    args = ap.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    vol = ct256()
    lo, hi = float(vol.min()), float(vol.max())
    tf = preset("ct-bone", lo, hi)
    rows = []
    angles = [30.0 + 10.0 * k for k in range(args.repeat + 1)]
    for shade in (False, True):
        vr = VtkRenderer(vol, tf, lo, hi, shade, args.workers)
        times = [vr.render(a, 20.0) for a in angles]
        vr.render(30.0, 20.0)
        from PIL import Image

        Image.fromarray(np.ascontiguousarray(vr.image())).save(
            args.out / f"peer_vtk_{'shaded' if shade else 'unshaded'}.png"
        )
        vtk_first, vtk_re = times[0], statistics.median(times[1:])
        rows.append({"renderer": "vtk-fixedpoint", "mode": "post",
                     "shading": "phong" if shade else "none", "first_s": round(vtk_first, 4),
                     "rerender_s": round(vtk_re, 4), "vtk_over_volpack": 1.0})  # fmt: skip
        print(f"vtk shade={shade}: first {vtk_first:.3f} s, re-render {vtk_re:.3f} s", flush=True)
        modes = [("post", "phong"), ("preintegrated", "phong"), ("preintegrated", "centroid")]
        for cls, shading in modes:
            shading = shading if shade else "none"
            if not shade and cls == "preintegrated" and rows[-1]["mode"] == "preintegrated":
                continue
            render(vol, tf=tf, camera=Camera(size=(16, 16)), classification=cls, shading=shading)
            times = []
            for a in angles:
                cam = Camera(azimuth=a, elevation=20.0, size=(SIZE, SIZE))
                t = time.perf_counter()
                img = render(vol, tf=tf, camera=cam, step=STEP, classification=cls,
                             shading=shading, workers=args.workers)  # fmt: skip
                times.append(time.perf_counter() - t)
                if a == angles[0]:
                    save_png(args.out / f"peer_volpack_{cls}_{shading}.png", img, force=True)
            first, re = times[0], statistics.median(times[1:])
            rows.append({"renderer": "volpack", "mode": cls, "shading": shading,
                         "first_s": round(first, 4), "rerender_s": round(re, 4),
                         "vtk_over_volpack": round(vtk_re / re, 3)})  # fmt: skip
            print(f"volpack {cls}/{shading}: first {first:.3f} s, re-render {re:.3f} s, "
                  f"VTK/volpack {vtk_re / re:.2f}", flush=True)  # fmt: skip
    with open(args.out / "peers.csv", "w", newline="") as f:
        wr = csv.DictWriter(f, fieldnames=list(rows[0]))
        wr.writeheader()
        wr.writerows(rows)
    print(f"wrote {args.out / 'peers.csv'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
