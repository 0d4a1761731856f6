"""Tetrahedral meshes in and out through meshio, and splitting other cells into tets.

:func:`read_mesh` accepts any volume mesh meshio reads (VTU, legacy VTK, Gmsh, Medit,
XDMF, DOLFIN XML, Abaqus, TetGen, ...; a ``.gz`` of one too). Tetrahedra are kept;
quadratic tets (tetra10) keep their four corners and drop the mid-edge nodes, with a
:class:`MeshWarning`; hexahedra, wedges and pyramids are refused unless
``tetrahedralize=True`` splits them. Lower-dimensional cells (boundary triangles, edges,
points) are dropped with a warning. Point data and the cell data of the kept cells come
along; other meshio extras (field data, sets) do not.

The split is conforming without new vertices: each cell is coned from its vertex of
smallest global index to the faces that do not hold it, and each quadrilateral face is
cut along the diagonal through its own smallest vertex. Two cells sharing a quad face
both cut it the same way, because the rule looks at global indices only.
"""

from __future__ import annotations

import contextlib
import gzip
import io
import os
import shutil
import tempfile
import warnings

import numpy as np

from ..errors import FormatError
from . import MESH_EXTENSIONS, is_mesh_path
from .mesh import TetMesh, signed_volumes

__all__ = [
    "MESH_EXTENSIONS",
    "MeshWarning",
    "is_mesh_path",
    "read_mesh",
    "tetrahedralize",
    "write_mesh",
]


# libraries meshio imports for one format -> the volpack extra that installs them
_EXTRAS = {"netCDF4": "exodus", "h5py": "", "lxml": ""}


class MeshWarning(UserWarning):
    """Something of the input mesh was dropped or changed on reading."""


# Outward-oriented faces (right-hand normal out of the cell) in VTK/meshio node order.
CELL_FACES = {
    "hexahedron": [[0, 4, 7, 3], [1, 2, 6, 5], [0, 1, 5, 4], [3, 7, 6, 2], [0, 3, 2, 1], [4, 5, 6, 7]],
    "wedge": [[0, 1, 2], [3, 5, 4], [0, 3, 4, 1], [1, 4, 5, 2], [2, 5, 3, 0]],
    "pyramid": [[0, 3, 2, 1], [0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]],
}  # fmt: skip
_VOLUME_CELLS = ("tetra", "tetra10", *CELL_FACES)
_SECOND_ORDER = {"hexahedron20": "hexahedron", "hexahedron27": "hexahedron", "wedge15": "wedge",
                 "wedge18": "wedge", "pyramid13": "pyramid", "pyramid14": "pyramid"}  # fmt: skip
_CORNERS = {"hexahedron": 8, "wedge": 6, "pyramid": 5}


def read_mesh(path: str, *, tetrahedralize: bool = False) -> TetMesh:
    """Read a tetrahedral mesh with meshio (see the module docstring for what is kept)."""
    import meshio

    # meshio prints its warnings (one per unknown XML entry: thousands for DOLFIN files);
    # keep them and say it once
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        mesh = _read(meshio, path, tetrahedralize)
    said = [ln.strip() for ln in (out.getvalue() + err.getvalue()).splitlines() if ln.strip()]
    if said:
        warnings.warn(
            f"{path}: meshio said {len(said)} line(s), e.g. {said[0]!r}", MeshWarning, stacklevel=2
        )
    return mesh


def _read(meshio, path: str, tetrahedralize: bool) -> TetMesh:
    try:
        if os.fspath(path).lower().endswith(".gz"):
            with tempfile.TemporaryDirectory(prefix="volpack-") as d:
                inner = os.path.join(d, os.path.basename(os.fspath(path))[:-3])
                with gzip.open(path, "rb") as src, open(inner, "wb") as dst:
                    shutil.copyfileobj(src, dst)
                m = meshio.read(inner)
        else:
            m = meshio.read(path)
    except (OSError, FormatError):
        raise
    except ModuleNotFoundError as e:  # meshio imports a format's library when it reads one
        extra = _EXTRAS.get(e.name or "", "")
        hint = f": pip install 'volpack[{extra}]'" if extra else ""
        raise FormatError(
            f"{path}: expected {e.name} to read this mesh format, found it missing{hint}"
        ) from None
    except KeyError as e:  # meshio looks up the fields it needs by name
        raise FormatError(
            f"{path}: expected the field {e} in this {os.path.splitext(path)[1]} mesh, found it "
            f"missing (a damaged or unsupported file)"
        ) from None
    except Exception as e:  # meshio raises ReadError, ValueError, IndexError, ...
        said = str(e).strip() or "no message"
        raise FormatError(
            f"{path}: expected a mesh meshio can read, found {type(e).__name__}: {said}"
        ) from None
    return from_meshio(m, tetrahedralize=tetrahedralize, source=os.fspath(path))


def from_meshio(m, *, tetrahedralize: bool = False, source: str = "mesh") -> TetMesh:
    """Build a :class:`TetMesh` from a ``meshio.Mesh`` (see :func:`read_mesh`)."""
    points = np.asarray(m.points)
    if points.ndim != 2 or points.shape[1] not in (2, 3):
        raise FormatError(f"{source}: expected points of shape (n, 3), found {points.shape}")
    if points.shape[1] == 2:
        raise FormatError(f"{source}: expected a 3-D mesh, found 2-D points")
    blocks, kept_data = [], {}
    dropped, others = set(), []
    mid_nodes = None
    for bi, block in enumerate(m.cells):
        kind, data = block.type, np.asarray(block.data, dtype=np.int64)
        if kind in _SECOND_ORDER:
            warnings.warn(
                f"{source}: {kind} cells keep their {_CORNERS[_SECOND_ORDER[kind]]} corners "
                "(mid-edge nodes dropped)",
                MeshWarning,
                stacklevel=2,
            )
            kind = _SECOND_ORDER[kind]
            mid_nodes = _mark(mid_nodes, len(points), data[:, _CORNERS[kind] :])
            data = data[:, : _CORNERS[kind]]
        if kind == "tetra10":
            warnings.warn(
                f"{source}: {len(data)} quadratic tets (tetra10) keep their 4 corners; "
                "the mid-edge nodes are dropped",
                MeshWarning,
                stacklevel=2,
            )
            mid_nodes = _mark(mid_nodes, len(points), data[:, 4:])
            kind, data = "tetra", data[:, :4]
        if kind not in _VOLUME_CELLS:
            dropped.add(kind)
            continue
        if kind != "tetra":
            others.append(kind)
        blocks.append((kind, data, bi))
    if dropped:
        warnings.warn(
            f"{source}: dropped cells that are not volume cells: {', '.join(sorted(dropped))}",
            MeshWarning,
            stacklevel=2,
        )
    if others and not tetrahedralize:
        raise FormatError(
            f"{source}: expected tetrahedra only, found {', '.join(sorted(set(others)))} cells; "
            "pass tetrahedralize=True to split them into tetrahedra"
        )
    tets, rows = [], []
    for kind, data, bi in blocks:
        if kind == "tetra":
            t, src = data, np.arange(len(data))
        else:
            t, src = _split_cells(kind, data, points)
        tets.append(t)
        rows.append((bi, src))
    if not blocks or not sum(len(t) for t in tets):
        found = ", ".join(sorted(dropped)) or "no cells"
        raise FormatError(
            f"{source}: expected a volume mesh with tetrahedra (or cells to split into them), "
            f"found {found}; volpack codes tetrahedral meshes only"
        )
    tets_all = np.concatenate(tets)
    for name, per_block in (m.cell_data or {}).items():
        parts = []
        for bi, src in rows:
            parts.append(np.asarray(per_block[bi])[src])
        if parts:
            kept_data[name] = np.concatenate(parts)
    point_data = {k: np.asarray(v) for k, v in (m.point_data or {}).items()}
    if mid_nodes is not None:
        # mid-edge nodes of quadratic cells are no vertices any more: drop and renumber
        corner = np.zeros(len(points), dtype=bool)
        corner[tets_all.reshape(-1)] = True
        keep = corner | ~mid_nodes
        remap = np.cumsum(keep) - 1
        tets_all = remap[tets_all]
        points = points[keep]
        point_data = {k: v[keep] for k, v in point_data.items()}
    return TetMesh(points, tets_all, point_data, kept_data)


def _mark(mask, n, nodes):
    mask = np.zeros(n, dtype=bool) if mask is None else mask
    mask[nodes.reshape(-1)] = True
    return mask


def tetrahedralize(kind: str, cells: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Split hexahedra, wedges or pyramids into positively oriented tets (no new vertices)."""
    return _split_cells(kind, np.asarray(cells, dtype=np.int64), points)[0]


def _split_cells(kind: str, cells: np.ndarray, points) -> tuple[np.ndarray, np.ndarray]:
    """Tets of each cell and the cell each tet came from (see the module docstring).

    Node-order conventions differ between formats (a Gmsh prism is a mirrored VTK
    wedge), so a cell whose tets add up to a negative volume has them all flipped.
    """
    faces = CELL_FACES[kind]
    nc = len(cells)
    apex_local = np.argmin(cells, axis=1)
    out, src = [], []
    for face in faces:
        f = np.asarray(face)
        fv = cells[:, f]  # (nc, k) global vertex ids of this face, outward order
        holds = (f[None, :] == apex_local[:, None]).any(axis=1)
        apex = cells[np.arange(nc), apex_local]
        if len(face) == 3:
            tris = [fv]
        else:  # cut the quad along the diagonal through its smallest vertex
            r = np.argmin(fv, axis=1)
            q = np.stack([fv[np.arange(nc), (r + i) % 4] for i in range(4)], axis=1)
            tris = [q[:, [0, 1, 2]], q[:, [0, 2, 3]]]
        for tri in tris:
            # outward (a, b, c) with the apex inside: (a, c, b, apex) is right-handed
            t = np.stack([tri[:, 0], tri[:, 2], tri[:, 1], apex], axis=1)
            out.append(t[~holds])
            src.append(np.nonzero(~holds)[0])
    tets = np.concatenate(out)
    src_all = np.concatenate(src)
    order = np.argsort(src_all, kind="stable")  # keep the tets of one cell together
    tets, src_all = tets[order], src_all[order]
    cell_vol = np.bincount(src_all, signed_volumes(points, tets), minlength=nc)
    flip = cell_vol[src_all] < 0
    tets[flip] = tets[flip][:, [0, 2, 1, 3]]
    return tets, src_all


def to_meshio(mesh: TetMesh):
    """Return a ``meshio.Mesh`` with one tetra block (point and cell data attached)."""
    import meshio

    return meshio.Mesh(
        mesh.points,
        [("tetra", mesh.tets)],
        point_data=dict(mesh.point_data),
        cell_data={k: [v] for k, v in mesh.cell_data.items()},
    )


def write_mesh(mesh: TetMesh, path: str, *, force: bool = False) -> None:
    """Write ``mesh`` with meshio, atomically (a temporary file beside ``path``, renamed)."""
    import meshio

    from ..format.atomic import atomic_path

    p = os.fspath(path)
    low = p.lower()
    suffix = next(
        (e for e in sorted(MESH_EXTENSIONS, key=len, reverse=True) if low.endswith(e)), ""
    )
    if not suffix:
        raise FormatError(
            f"{p}: expected a mesh file suffix meshio writes ({', '.join(MESH_EXTENSIONS[:6])}, ...)"
        )
    with atomic_path(p, force=force, suffix=suffix) as tmp:
        try:
            meshio.write(tmp, to_meshio(mesh))
        except Exception as e:
            if isinstance(e, (OSError, FormatError)):
                raise
            raise FormatError(f"{p}: meshio could not write the mesh: {e}") from None


def describe_mesh_file(path: str) -> dict:
    """The report of a mesh file (:func:`volpack.tetra.mesh.report`, read with its
    non-tetrahedral cells split) with what reading it warned about, as JSON types."""
    from .mesh import report

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        mesh = read_mesh(path, tetrahedralize=True)
    d = {"format": "mesh", "path": path, **report(mesh)}
    d["warnings"] = [str(w.message) for w in caught]
    return d
