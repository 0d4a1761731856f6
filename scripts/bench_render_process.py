"""The whole `volpack render` process against a VTK script doing the same job.

What a user waits for when previewing a file from the shell: start the interpreter, read
the file, build whatever the renderer needs, render one 512 x 512 image, write the PNG,
exit. Both sides read the same NRRD file (raw encoding, the volume's own dtype and
spacing) with their own reader and render the same orthographic view with the same
control points (``bench_render_peers.tf_points``), step and threads:

* ``volpack``: ``volpack render FILE OUT.png --tf TF.json --no-fit --step S -j W
  --shading phong|none`` (the console entry point of the Python running this script,
  kernels from the on-disk cache as in every run after the first: one untimed run of
  each side per case comes first);
* ``vtk``: a Python script that imports only the VTK modules it needs (as VTK's own
  examples do), reads the file with ``vtkNrrdReader``, renders with
  ``vtkFixedPointVolumeRayCastMapper`` (automatic sampling off, ``SampleDistance`` =
  the step in world units, ``ImageSampleDistance`` 1), off screen through EGL, and writes
  the PNG with ``vtkPNGWriter``. This file runs itself with ``--vtk-child`` for it.

* ``served`` (with ``--serve``): the same ``volpack render`` command while a ``volpack
  serve`` of this install listens (started once, kernels warm, before the first case):
  the process forwards its arguments over the server's socket and prints its answer.
  The plain ``volpack`` row then runs with ``VOLPACK_SERVE=0``.

The processes alternate, ``--rounds`` times per case; the median wall time of each
is kept, with the children's CPU time. Writes ``process.csv`` and ``process.png`` under
``--out``, and ``floor.csv``: the start-up any numba-based process pays (see :func:`floor`).

Python bytecode: an installed package has its ``.pyc`` files (pip writes them), so the
children read and write theirs in a private cache under the temporary folder (the
untimed first run writes them) even where ``PYTHONDONTWRITEBYTECODE`` is set, as on the
machines this ran on, where an editable install otherwise compiled every imported
module of volpack from source in every process (about 0.1 s). ``--no-bytecode`` keeps
the environment as it is (how this measured before session 15).

    python scripts/bench_render_process.py [--rounds 3] [--out results/render] [--no-bytecode]
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
VOLUMES = ("ct_head", "mri_mni152", "zmap_neurovault")


def vtk_child(argv) -> int:
    """Render FILE into OUT.png with VTK's CPU ray caster; CASE is a JSON object."""
    os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
    import vtkmodules.vtkRenderingOpenGL2  # noqa: F401  (the render window's back end)
    import vtkmodules.vtkRenderingVolumeOpenGL2  # noqa: F401  (the mapper's image display)
    from vtkmodules.vtkCommonDataModel import vtkPiecewiseFunction
    from vtkmodules.vtkIOImage import vtkNrrdReader, vtkPNGWriter
    from vtkmodules.vtkRenderingCore import (
        vtkColorTransferFunction,
        vtkRenderer,
        vtkRenderWindow,
        vtkVolume,
        vtkVolumeProperty,
        vtkWindowToImageFilter,
    )
    from vtkmodules.vtkRenderingVolume import vtkFixedPointVolumeRayCastMapper

    path, out, case = argv[0], argv[1], json.loads(argv[2])
    reader = vtkNrrdReader()
    reader.SetFileName(path)
    reader.Update()
    img = reader.GetOutput()
    sx, sy, sz = img.GetSpacing()
    ctf, otf = vtkColorTransferFunction(), vtkPiecewiseFunction()
    for v, r, g, b, a in case["points"]:
        ctf.AddRGBPoint(v, r, g, b)
        otf.AddPoint(v, a)
    prop = vtkVolumeProperty()
    prop.SetColor(ctf)
    prop.SetScalarOpacity(otf)
    prop.SetScalarOpacityUnitDistance(min(sx, sy, sz))
    prop.SetInterpolationTypeToLinear()
    if case["shade"]:
        ka, kd, ks, shin = case["phong"]
        prop.ShadeOn()
        prop.SetAmbient(ka)
        prop.SetDiffuse(kd)
        prop.SetSpecular(ks)
        prop.SetSpecularPower(shin)
    mapper = vtkFixedPointVolumeRayCastMapper()
    mapper.SetInputConnection(reader.GetOutputPort())
    mapper.SetAutoAdjustSampleDistances(0)
    mapper.SetSampleDistance(case["step"] * min(sx, sy, sz))
    mapper.SetImageSampleDistance(1.0)
    mapper.SetNumberOfThreads(case["workers"])
    actor = vtkVolume()
    actor.SetMapper(mapper)
    actor.SetProperty(prop)
    ren = vtkRenderer()
    ren.AddVolume(actor)
    ren.SetBackground(0, 0, 0)
    win = vtkRenderWindow()
    win.SetOffScreenRendering(1)
    win.AddRenderer(ren)
    win.SetSize(case["size"], case["size"])
    cam = ren.GetActiveCamera()
    cam.ParallelProjectionOn()
    centre, fwd, radius = case["centre"], case["forward"], case["radius"]
    cam.SetFocalPoint(*centre)
    cam.SetPosition(*(c - 4 * radius * f for c, f in zip(centre, fwd)))
    cam.SetViewUp(0, 0, 1)
    cam.SetParallelScale(radius)
    ren.ResetCameraClippingRange()
    win.Render()
    grab = vtkWindowToImageFilter()
    grab.SetInput(win)
    grab.ReadFrontBufferOff()
    writer = vtkPNGWriter()
    writer.SetFileName(out)
    writer.SetInputConnection(grab.GetOutputPort())
    writer.Write()
    return 0


def timed(cmd: list[str], env: dict) -> tuple[float, float]:
    """Wall seconds and the child's CPU seconds (user + system) of one run of ``cmd``."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t = time.perf_counter()
    done = subprocess.run(cmd, env=env, capture_output=True, text=True)
    wall = time.perf_counter() - t
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if done.returncode:
        raise SystemExit(f"{cmd[:3]} failed ({done.returncode}): {done.stderr.strip()[-400:]}")
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu


def run_case(name, path, shape, spacing, points, tfk, shade, args, tmp, rows, env, served_env=None):
    from bench_render_peers import KA, KD, KS, SHIN, view_frame

    from volpack.render.transfer import TransferFunction

    centre, fwd, radius = view_frame(shape, spacing, 30.0)
    case = {"points": [list(p) for p in points], "shade": shade, "phong": [KA, KD, KS, SHIN],
            "step": args.step, "workers": args.workers, "size": args.size,
            "centre": [float(c) for c in centre], "forward": [float(f) for f in fwd],
            "radius": float(radius)}  # fmt: skip
    tf_path = tmp / f"{name}-{tfk}.json"
    tf_path.write_text(TransferFunction(points=tuple(points), name=tfk).to_json())
    env = dict(env, VTK_DEFAULT_OPENGL_WINDOW="vtkEGLRenderWindow")
    volpack = [str(Path(sys.executable).with_name("volpack")), "render", str(path),
               str(tmp / "volpack.png"), "--force", "--tf", str(tf_path), "--no-fit",
               "--step", str(args.step), "--size", f"{args.size}x{args.size}",
               "-j", str(args.workers), "--shading", "phong" if shade else "none"]  # fmt: skip
    vtk = [sys.executable, __file__, "--vtk-child", str(path), str(tmp / "vtk.png"),
           json.dumps(case)]  # fmt: skip
    runs: dict[str, list[tuple[float, float]]] = {"volpack": [], "vtk": []}
    sides = [("volpack", volpack, dict(env, VOLPACK_SERVE="0") if served_env else env),
             ("vtk", vtk, env)]  # fmt: skip
    if served_env is not None:
        runs["served"] = []
        served_png = str(tmp / "served.png")
        sides.append(("served", [served_png if a == str(tmp / "volpack.png") else a
                                 for a in volpack], served_env))  # fmt: skip
    for _, cmd, e in sides:
        timed(cmd, e)  # untimed: compiles kernels for a dtype not seen before, warms caches
    for _ in range(args.rounds):  # alternate, so machine load hits all alike
        for key, cmd, e in sides:
            runs[key].append(timed(cmd, e))
    if served_env is not None:
        if Path(served_png).read_bytes() != (tmp / "volpack.png").read_bytes():
            raise SystemExit(f"{name} {tfk}: the served image differs from the local one")
        status = subprocess.run([volpack[0], "serve", "--status", "--json"], env=served_env,
                                capture_output=True, text=True, check=True)  # fmt: skip
        if not json.loads(status.stdout)["listening"]:  # else the 'served' runs ran locally
            raise SystemExit(f"{name} {tfk}: the server stopped listening")
    med = {k: (statistics.median(w for w, _ in v), statistics.median(c for _, c in v))
           for k, v in runs.items()}  # fmt: skip
    row = {"volume": name, "tf": tfk, "shading": "phong" if shade else "none",
           "volpack_wall_s": round(med["volpack"][0], 3),
           "volpack_cpu_s": round(med["volpack"][1], 3),
           "vtk_wall_s": round(med["vtk"][0], 3), "vtk_cpu_s": round(med["vtk"][1], 3),
           "wall_ratio": round(med["volpack"][0] / med["vtk"][0], 3)}  # fmt: skip
    if "served" in med:
        row.update(served_wall_s=round(med["served"][0], 3), served_cpu_s=round(med["served"][1], 3),
                   served_ratio=round(med["served"][0] / med["vtk"][0], 3))  # fmt: skip
    rows.append(row)
    print(f"  {name:16s} {tfk:6s} {row['shading']:5s} volpack {row['volpack_wall_s']:6.2f} s "
          f"(cpu {row['volpack_cpu_s']:5.2f})  vtk {row['vtk_wall_s']:6.2f} s "
          f"(cpu {row['vtk_cpu_s']:5.2f})  volpack/vtk {row['wall_ratio']:.2f}"
          + (f"  served {row['served_wall_s']:5.2f} s ({row['served_ratio']:.2f})"
             if "served" in med else ""), flush=True)


FLOOR_KERNEL = """
import numpy as np
from volpack._jit import kernel

@kernel()
def total(a):
    s = 0.0
    for i in range(a.size):
        s += a[i]
    return s

total(np.ones(4))
"""


def floor(args, tmp: Path, env: dict) -> list[dict]:
    """What any process pays before it renders: the interpreter with numpy, and one that
    also imports numba and calls one kernel from the on-disk cache (numba's import, its
    typing context made ready, one cached kernel loaded). No numba-based ``render`` can
    start faster than the second; it is set beside the VTK script's whole run."""
    (tmp / "floor_kernel.py").write_text(FLOOR_KERNEL)
    cmds = {"python + numpy": [sys.executable, "-c", "import numpy"],
            "python + numpy + numba, one cached kernel": [sys.executable,
                                                          str(tmp / "floor_kernel.py")]}
    timed(cmds["python + numpy + numba, one cached kernel"], env)  # compiles, caches
    rows = []
    for what, cmd in cmds.items():
        runs = [timed(cmd, env) for _ in range(max(5, args.rounds))]
        rows.append({"process": what, "wall_s": round(statistics.median(w for w, _ in runs), 3),
                     "cpu_s": round(statistics.median(c for _, c in runs), 3)})
        print(f"  floor: {what:44s} {rows[-1]['wall_s']:6.3f} s (cpu {rows[-1]['cpu_s']:5.3f})",
              flush=True)
    return rows


def chart(rows, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    labels = [f"{r['volume']}\n{r['tf']} {r['shading']}" for r in rows]
    x = range(len(rows))
    fig, ax = plt.subplots(figsize=(max(7.0, 0.8 * len(rows)), 4.5))
    served = "served_wall_s" in rows[0]
    w = 0.27 if served else 0.4
    ax.bar([i - w / 2 - (w / 2 if served else 0) for i in x], [r["volpack_wall_s"] for r in rows],
           w, label="volpack render")  # fmt: skip
    if served:
        ax.bar(list(x), [r["served_wall_s"] for r in rows], w, label="volpack render, served")
    ax.bar([i + w / 2 + (w / 2 if served else 0) for i in x], [r["vtk_wall_s"] for r in rows],
           w, label="VTK script")  # fmt: skip
    ax.set_xticks(list(x))
    ax.set_xticklabels(labels, fontsize=6, rotation=60, ha="right")
    ax.set_ylabel("wall seconds, whole process (median)")
    ax.set_title("File to PNG: volpack render vs a VTK script (same view, TF, step, threads)")
    ax.legend(fontsize=8)
    ax.grid(axis="y", alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if argv[:1] == ["--vtk-child"]:
        return vtk_child(argv[1:])
    sys.path.insert(0, str(ROOT / "scripts"))
    import datasets
    from bench_render_peers import tf_base, tf_points

    from volpack.api import write_volume
    from volpack.volume import Volume

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=ROOT / "results" / "render")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--size", type=int, default=512)
    ap.add_argument("--step", type=float, default=0.5)
    ap.add_argument("--volumes", nargs="+", default=list(VOLUMES))
    ap.add_argument("--serve", action="store_true",
                    help="also time volpack render through a warm `volpack serve`")
    ap.add_argument("--bytecode", action=argparse.BooleanOptionalAction, default=True,
                    help="children use a private bytecode cache (module docstring)")
    args = ap.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    rows: list[dict] = []
    with tempfile.TemporaryDirectory(prefix="volpack-bench-") as d:
        tmp = Path(d)
        env = dict(os.environ)
        if args.bytecode:
            env.pop("PYTHONDONTWRITEBYTECODE", None)
            env["PYTHONPYCACHEPREFIX"] = str(tmp / "pycache")
        print(f"bytecode: {'private cache' if args.bytecode else 'as the environment has it'}",
              flush=True)
        floors = floor(args, tmp, env)
        served_env = None
        if args.serve:
            (tmp / "serve").mkdir(mode=0o700)
            served_env = dict(env, VOLPACK_SERVE_DIR=str(tmp / "serve"))
            exe = str(Path(sys.executable).with_name("volpack"))
            subprocess.run([exe, "serve", "--detach", "--idle", "0"], env=served_env, check=True)
        for name in args.volumes:
            vol, spacing, _ = datasets.load(name)
            spacing = tuple(float(s) for s in spacing)
            path = tmp / f"{name}.nrrd"
            write_volume(Volume(vol, spacing=spacing), str(path))
            print(f"{name} {vol.shape} {vol.dtype} spacing {spacing}", flush=True)
            for tfk in ("semi", "opaque"):
                points = tf_points(tfk, *tf_base(vol))
                for shade in (False, True):
                    run_case(name, path, vol.shape, spacing, points, tfk, shade, args, tmp,
                             rows, env, served_env)
        if served_env is not None:
            subprocess.run([exe, "serve", "--stop"], env=served_env, check=True)
    with open(args.out / "process.csv", "w", newline="") as f:
        wr = csv.DictWriter(f, fieldnames=list(rows[0]))
        wr.writeheader()
        wr.writerows(rows)
    with open(args.out / "floor.csv", "w", newline="") as f:
        wr = csv.DictWriter(f, fieldnames=list(floors[0]))
        wr.writeheader()
        wr.writerows(floors)
    chart(rows, args.out / "process.png")
    print(f"wrote {args.out / 'process.csv'}, floor.csv and process.png")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
