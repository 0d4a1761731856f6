"""Fill real triangle surfaces with tetrahedra, the same way every time, for bench_tetra.py.

A recipe (``RECIPES``) names a surface of ``datasets.SURFACE_DATASETS``, a mesher and its
fixed parameters:

* ``tetgen`` (pyvista's TetGen wrapper) with ``quality=True``: a constrained Delaunay
  mesh of a closed surface, refined until no tet has a radius-edge ratio over
  ``minratio`` or a dihedral angle under ``mindihedral`` degrees;
* ``gmsh``: the STL is split into patches at sharp edges and reparametrised (gmsh's
  ``classifySurfaces`` and ``createGeometry``, as in gmsh tutorial 13), open ends are
  closed by plane caps (the aneurysm's vessel ends), and the volume is meshed by
  Delaunay on one thread with a fixed random seed.

pytetwild (fTetWild) is left out: two single-threaded runs on the aneurysm surface gave
two different meshes, so a benchmark row could not be reproduced.

A meshed surface is cached as ``<data>/meshed/<recipe>-<mesher>-<version>-<key>.vtu``,
``key`` hashing the parameters and the surface file's bytes; a cached mesh is read back
instead of meshing again, so a rerun measures the same tets even on another mesher build
(a new version gets a new file). The meshers are imported only here, and only when
a mesh is not cached yet: ``pip install -e .[bench]`` brings them.

    python scripts/mesh_surfaces.py                      # every recipe: sizes, seconds, sha256
    python scripts/mesh_surfaces.py --force femur_tetgen # mesh again, ignoring the cache
"""

from __future__ import annotations

import argparse
import hashlib
import json
import math
import sys
import tempfile
import time
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import datasets  # noqa: E402
import fetch_data  # noqa: E402

from volpack.tetra.formats import read_mesh, write_mesh  # noqa: E402
from volpack.tetra.mesh import TetMesh  # noqa: E402


@dataclass(frozen=True)
class Recipe:
    """How one surface becomes a tetrahedral mesh: ``mesher`` run with ``params``."""

    surface: str
    mesher: str
    params: dict = field(default_factory=dict)


# TetGen's quality bounds of pyvista-tetgen's own examples (radius-edge 1.5, 20 degrees)
_TETGEN_QUALITY = {"quality": True, "order": 1, "minratio": 1.5, "mindihedral": 20.0}

RECIPES: dict[str, Recipe] = {
    "femur_tetgen": Recipe("femur", "tetgen", _TETGEN_QUALITY),
    "hinge_tetgen": Recipe("hinge", "tetgen", _TETGEN_QUALITY),
    "part1_tetgen": Recipe("part1", "tetgen", _TETGEN_QUALITY),
    "t13_tetgen": Recipe("t13", "tetgen", _TETGEN_QUALITY),
    # tutorial 13's own settings: 40-degree patches, element size 4
    "t13_gmsh": Recipe(
        "t13", "gmsh", {"angle": 40.0, "parametrizable": False, "size_factor": 1.0, "size_max": 4.0}
    ),
    # the aneurysm example's size factor 0.1 (of the bounding box); caps on the 3 open ends
    "aneurysm_gmsh": Recipe(
        "aneurysm_stl", "gmsh", {"angle": 40.0, "parametrizable": True, "size_factor": 0.1}
    ),
}


def read_surface(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """Read a triangle surface with meshio: ``(points float64 (n, 3), triangles int32)``."""
    import meshio

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # meshio's ASCII-STL size probe overflows harmlessly
        m = meshio.read(str(path))
    kinds = {c.type for c in m.cells}
    if kinds != {"triangle"}:
        raise ValueError(f"{path}: expected a surface of triangles only, found cells {kinds}")
    tris = np.concatenate([c.data for c in m.cells]).astype(np.int32)
    return np.ascontiguousarray(m.points, dtype=np.float64), tris


def mesher_version(mesher: str) -> str:
    if mesher == "tetgen":
        import tetgen

        return tetgen.__version__
    if mesher == "gmsh":
        import gmsh

        return gmsh.__version__
    raise KeyError(f"unknown mesher {mesher!r}; expected tetgen or gmsh")


def cache_path(name: str, surface_file: Path, version: str) -> Path:
    """Where recipe ``name`` meshed with mesher ``version`` is cached."""
    r = RECIPES[name]
    h = hashlib.sha256(json.dumps(r.params, sort_keys=True).encode())
    h.update(hashlib.sha256(surface_file.read_bytes()).digest())
    return datasets.data_dir() / "meshed" / f"{name}-{r.mesher}-{version}-{h.hexdigest()[:12]}.vtu"


def meshed(name: str, tmp: Path, force: bool = False) -> tuple[TetMesh, str]:
    """Recipe ``name``'s tetrahedral mesh (from the cache, else meshed and cached), and
    the mesher with its version (e.g. ``"tetgen 0.8.4"``)."""
    r = RECIPES[name]
    surface_file, _ = fetch_data.fetch_dataset(datasets.SURFACE_DATASETS[r.surface], tmp)
    version = mesher_version(r.mesher)
    target = cache_path(name, surface_file, version)
    if force or not target.is_file():
        points, tets = _MESHERS[r.mesher](surface_file, r.params)
        target.parent.mkdir(parents=True, exist_ok=True)
        write_mesh(compact(points, tets), str(target), force=True)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return read_mesh(str(target)), f"{r.mesher} {version}"


def compact(points: np.ndarray, tets: np.ndarray) -> TetMesh:
    """The mesh with the vertices no tet uses dropped (the rest keep their order)."""
    used = np.unique(tets)
    index = np.full(len(points), -1, dtype=np.int64)
    index[used] = np.arange(len(used))
    return TetMesh(points[used], index[tets])


def tetgen_mesh(surface_file: Path, params: dict) -> tuple[np.ndarray, np.ndarray]:
    import tetgen

    points, tris = read_surface(surface_file)
    nodes, elems = tetgen.TetGen(points, tris).tetrahedralize(**params)[:2]
    return np.asarray(nodes, dtype=np.float64), np.asarray(elems, dtype=np.int64)


def gmsh_mesh(surface_file: Path, params: dict) -> tuple[np.ndarray, np.ndarray]:
    import gmsh

    gmsh.initialize(readConfigFiles=False)
    try:
        for key, value in {
            "General.Terminal": 0, "General.NumThreads": 1, "Mesh.RandomSeed": 1,
            "Mesh.Algorithm": 1, "Mesh.Algorithm3D": 1,  # MeshAdapt surfaces, Delaunay volume
            "Mesh.MeshSizeFactor": params["size_factor"],
            "Mesh.MeshSizeMax": params.get("size_max", 1e22),
        }.items():  # fmt: skip
            gmsh.option.setNumber(key, value)
        gmsh.merge(str(surface_file))
        # patches split at edges sharper than `angle`; curves are never split at an angle
        gmsh.model.mesh.classifySurfaces(
            math.radians(params["angle"]), True, params["parametrizable"], math.pi
        )
        gmsh.model.mesh.createGeometry()
        surfaces = [tag for _, tag in gmsh.model.getEntities(2)]
        # curves bounding one patch only are holes (open vessel ends): cap each loop
        holes = gmsh.model.getBoundary([(2, s) for s in surfaces], combined=True, oriented=False)
        if holes:
            loops = gmsh.model.geo.addCurveLoops([abs(c) for _, c in holes])
            surfaces += [gmsh.model.geo.addPlaneSurface([loop]) for loop in loops]
        gmsh.model.geo.addVolume([gmsh.model.geo.addSurfaceLoop(surfaces)])
        gmsh.model.geo.synchronize()
        gmsh.model.mesh.generate(3)
        tags, coords, _ = gmsh.model.mesh.getNodes()
        types, _, conn = gmsh.model.mesh.getElements(3)
    finally:
        gmsh.finalize()
    if list(types) != [4]:  # 4: the linear tetrahedron
        raise RuntimeError(f"{surface_file}: gmsh made volume elements of types {list(types)}")
    index = np.full(int(tags.max()) + 1, -1, dtype=np.int64)
    index[tags] = np.arange(len(tags))
    return coords.reshape(-1, 3), index[np.asarray(conn[0], dtype=np.int64).reshape(-1, 4)]


_MESHERS = {"tetgen": tetgen_mesh, "gmsh": gmsh_mesh}


def mesh_digest(mesh: TetMesh) -> str:
    """sha256 of the coordinates and tets: equal digests, the same mesh."""
    h = hashlib.sha256(np.ascontiguousarray(mesh.points, dtype="<f8").tobytes())
    h.update(np.ascontiguousarray(mesh.tets, dtype="<i8").tobytes())
    return h.hexdigest()[:16]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("names", nargs="*", help=f"recipes (default: all of {', '.join(RECIPES)})")
    ap.add_argument("--force", action="store_true", help="mesh again even if cached")
    args = ap.parse_args(argv)
    unknown = [n for n in args.names if n not in RECIPES]
    if unknown:
        ap.error(f"unknown recipe(s) {', '.join(unknown)}; expected some of {', '.join(RECIPES)}")
    with tempfile.TemporaryDirectory(prefix="volpack-fetch-") as tmp:
        for name in args.names or RECIPES:
            t0 = time.perf_counter()
            mesh, mesher = meshed(name, Path(tmp), force=args.force)
            print(
                f"{name:14s} {mesher:14s} {mesh.n_vertices:7d} vertices {mesh.n_tets:7d} tets "
                f"{time.perf_counter() - t0:6.1f} s  sha256 {mesh_digest(mesh)}"
            )
    return 0


if __name__ == "__main__":
    sys.exit(main())
