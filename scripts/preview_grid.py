"""Default previews: ``volpack render IN OUT.png`` with no flags, on eight different inputs,
tiled into ``results/preview/grid.png``; the share of each image the object spans goes to
``results/preview/coverage.csv``.

Inputs (real data from the cache that ``fetch_data.py`` fills, see ``datasets.py``):

* ``ct_head``: the InVesalius head CT, int16 Hounsfield units;
* ``ct_head`` as float32 (the same CT after a lossy float round trip would look so);
* ``mri_ch2``: the Colin27 T1 MRI, uint8;
* ``tgv_vorticity``: vorticity magnitude of a Taylor-Green vortex simulation, float32;
* ``nuclei_stardist``: a fluorescence-microscopy nuclei stack, uint16;
* ``liver_labels``: a CT liver segmentation (label map), drawn from an octree ``.vpk``
  (``volpack compress --octree``), so through the level-of-detail renderer;
* an Exodus II disk mesh (gmsh, 5k tets) with a temperature field, written by meshio;
* the DOLFIN aneurysm mesh (37,548 tets) without fields: a lit surface.

The coverage is measured on the PNG: the bounding box of the pixels brighter than 12/255
in any channel, as fractions of the width and height; ``span`` is the larger (the
framing aims at 0.80 along the tighter side).

    python scripts/preview_grid.py            # 512 x 512 previews (a few minutes)
    python scripts/preview_grid.py --size 256x256
    git archive d46eaef | tar -x -C /tmp/old   # the defaults before issue 24 part 7:
    python scripts/preview_grid.py --src /tmp/old --name before
"""

from __future__ import annotations

import argparse
import csv
import gzip
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent))

import datasets  # noqa: E402

from volpack import io as vio  # noqa: E402
from volpack.volume import Volume  # noqa: E402

OUT = HERE.parent / "results" / "preview"

# (panel name, what it is, how to make the input: a function(tmp) -> path)
PANELS = [
    ("ct_head", "CT, int16 HU (InVesalius head)"),
    ("ct_float", "CT as float32"),
    ("mri_ch2", "T1 MRI, uint8 (Colin27)"),
    ("tgv_vorticity", "simulation, float32 (Taylor-Green vorticity)"),
    ("nuclei_stardist", "microscopy, uint16 (StarDist nuclei)"),
    ("liver_octree", "label map as an octree .vpk (CGAL liver)"),
    ("disk_exodus", "Exodus II mesh with a field (gmsh disk)"),
    ("aneurysm", "tetrahedral mesh without fields (DOLFIN aneurysm)"),
]


def volume_input(name: str, tmp: Path, dtype=None) -> Path:
    a, spacing, _ = datasets.load(name)
    if dtype is not None:
        a = a.astype(dtype)
    path = tmp / f"{name}{'' if dtype is None else '_' + np.dtype(dtype).name}.nii.gz"
    vio.write_volume(Volume(a, spacing=spacing), str(path), force=True)
    return path


def octree_input(tmp: Path) -> Path:
    src = volume_input("liver_labels", tmp)
    out = tmp / "liver.vpk"
    run(["compress", str(src), str(out), "--octree", "--force"])
    return out


def disk_mesh(tmp: Path) -> Path:
    """A disk 2 wide and 0.15 thick, meshed by gmsh, with a temperature field: a hot
    spot off-centre plus a gradient through the thickness; written as Exodus II."""
    import gmsh
    import meshio

    gmsh.initialize()
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.occ.addCylinder(0, 0, 0, 0, 0, 0.15, 1.0)
        gmsh.model.occ.synchronize()
        gmsh.option.setNumber("Mesh.MeshSizeMax", 0.08)
        gmsh.option.setNumber("Mesh.RandomSeed", 1)
        gmsh.model.mesh.generate(3)
        tags, coords, _ = gmsh.model.mesh.getNodes()
        _, _, nodes = gmsh.model.mesh.getElements(3)
    finally:
        gmsh.finalize()
    pts = coords.reshape(-1, 3)
    index = np.zeros(int(tags.max()) + 1, np.int64)
    index[tags.astype(np.int64)] = np.arange(len(tags))
    tets = index[nodes[0].astype(np.int64)].reshape(-1, 4)
    r = np.hypot(pts[:, 0] - 0.3, pts[:, 1])
    temperature = 300 + 80 * np.exp(-((r / 0.35) ** 2)) + 10 * pts[:, 2]
    path = tmp / "disk.e"
    meshio.write(path, meshio.Mesh(pts, [("tetra", tets)], point_data={"temperature": temperature}))
    return path


def aneurysm_mesh(tmp: Path) -> Path:
    import fetch_data

    ds = datasets.MESH_DATASETS["aneurysm"]
    src, _ = fetch_data.fetch_dataset(ds, tmp)
    path = tmp / "aneurysm.xml"
    with gzip.open(src) as f, open(path, "wb") as g:
        shutil.copyfileobj(f, g)
    return path


SRC = HERE.parent  # the volpack tree whose command line draws (--src)


def run(args: list[str]) -> str:
    env = {**os.environ, "PYTHONPATH": str(SRC)}
    r = subprocess.run([sys.executable, "-m", "volpack", "-q", *args], capture_output=True,
                       text=True, cwd=SRC, env=env)  # fmt: skip
    if r.returncode:
        raise RuntimeError(f"volpack {' '.join(args)}: {r.stderr.strip()}")
    return r.stdout


def make_input(name: str, tmp: Path) -> Path:
    if name == "ct_float":
        return volume_input("ct_head", tmp, np.float32)
    if name == "liver_octree":
        return octree_input(tmp)
    if name == "disk_exodus":
        return disk_mesh(tmp)
    if name == "aneurysm":
        return aneurysm_mesh(tmp)
    return volume_input(name, tmp)


def span_of(png: Path) -> tuple[float, float]:
    from PIL import Image

    lit = np.asarray(Image.open(png).convert("RGB")).max(axis=2) > 12
    if not lit.any():
        return 0.0, 0.0
    rows, cols = np.flatnonzero(lit.any(axis=1)), np.flatnonzero(lit.any(axis=0))
    h, w = lit.shape
    return (cols[-1] - cols[0] + 1) / w, (rows[-1] - rows[0] + 1) / h


def tile(pngs: list[Path], labels: list[str], target: Path, cols: int = 4) -> None:
    from PIL import Image, ImageDraw

    images = [Image.open(p).convert("RGB") for p in pngs]
    w, h = images[0].size
    bar = 22
    rows = -(-len(images) // cols)
    grid = Image.new("RGB", (cols * w, rows * (h + bar)), (40, 40, 40))
    draw = ImageDraw.Draw(grid)
    for k, (im, label) in enumerate(zip(images, labels)):
        x, y = (k % cols) * w, (k // cols) * (h + bar)
        grid.paste(im, (x, y + bar))
        draw.text((x + 6, y + 5), label, fill=(230, 230, 230))
    grid.save(target)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--size", default=None, help="image WxH (default: the render default)")
    ap.add_argument("--only", nargs="*", help="panel names to draw")
    ap.add_argument("--src", help="draw with the volpack source tree in this folder (e.g. "
                    "an older commit from 'git archive'); output goes to results/preview/NAME/ "
                    "with --name")  # fmt: skip
    ap.add_argument("--name", default="", help="subfolder of results/preview for the output")
    args = ap.parse_args(argv)
    global SRC, OUT
    if args.src:
        SRC = Path(args.src).resolve()
    OUT = OUT / args.name if args.name else OUT
    OUT.mkdir(parents=True, exist_ok=True)
    rows, pngs, labels = [], [], []
    with tempfile.TemporaryDirectory(prefix="volpack-preview-") as t:
        tmp = Path(t)
        for name, what in PANELS:
            if args.only and name not in args.only:
                continue
            src = make_input(name, tmp)
            png = OUT / f"{name}.png"
            extra = ["--size", args.size] if args.size else []
            t0 = time.perf_counter()
            report = json.loads(run(["render", str(src), str(png), "--force", "--json", *extra]))
            seconds = time.perf_counter() - t0
            w, h = span_of(png)
            rows.append({"panel": name, "input": what, "tf": report["tf"] or "surface",
                         "width": round(w, 3), "height": round(h, 3), "span": round(max(w, h), 3),
                         "seconds": round(seconds, 2)})  # fmt: skip
            print(f"{name:16s} tf {rows[-1]['tf']:15s} span {max(w, h):.2f} "
                  f"(w {w:.2f}, h {h:.2f}) {seconds:5.1f} s  {what}")  # fmt: skip
            pngs.append(png)
            labels.append(f"{what}: tf {rows[-1]['tf']}, span {max(w, h):.2f}")
    if not args.only:
        tile(pngs, labels, OUT / "grid.png")
        with open(OUT / "coverage.csv", "w", newline="") as f:
            wr = csv.DictWriter(f, fieldnames=list(rows[0]))
            wr.writeheader()
            wr.writerows(rows)
        print(f"wrote {OUT / 'grid.png'} and {OUT / 'coverage.csv'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
