"""Tetrahedral meshes <-> ``.vpk``: the library calls behind ``volpack compress mesh.vtu``.

A mesh stream is a ``.vpk`` container (``formats/vpk-1.md``) whose header has
``kind: "mesh"``; its chunks, all at ``t = 0``, are keyed by ``node``:

* 0: the connectivity (:mod:`.cutborder`), which fixes the coding order;
* 1: the vertex coordinates in that order (:mod:`.geometry`);
* 2: with ``keep_order``, the input order of vertices, tets and tet rows;
* 3, 4, ...: one chunk per point or cell data field, in header order
  (:mod:`.attributes`).

The byte layout is ``formats/mesh-1.md``. The decoded mesh has the same tetrahedra with
vertices and tets renumbered in coding order, unless the stream keeps the order, in which
case every index comes back as it was. How a tet's row is ordered follows the input's
convention (header ``rows``):

* ``"parity"``: each row keeps its input orientation; a tet oriented against its face
  neighbours costs a flag, so a consistently oriented mesh pays nothing;
* ``"sorted"``: every input row was ascending (DOLFIN's UFC numbering, which gives the
  geometric orientation of each tet no meaning, so half of them look inverted); no
  orientation is coded and the decoder writes every row ascending again, in its own
  numbering, or exactly as given with ``keep_order``. About a bit per tet less;
* ``"oriented"`` (``--orient``): tets of negative volume were turned before coding.
"""

from __future__ import annotations

import itertools
import logging
import time
from collections.abc import Callable
from typing import Any, BinaryIO

import numpy as np

from .. import __version__
from ..errors import FormatError, LimitError, OptionError
from ..format.checked import CheckedReader
from .mesh import TetMesh, validate

__all__ = [
    "KIND_MESH",
    "MeshReader",
    "check_header",
    "compress",
    "compress_mesh",
    "decompress",
    "decompress_mesh",
    "info",
    "mesh_info",
    "open",
    "row_convention",
]

log = logging.getLogger(__name__)

KIND_MESH = "mesh"
KIND = KIND_MESH
FORMAT = "mesh-1"
# Chunk nodes (formats/mesh-1.md, section 2).
NODE_CONNECTIVITY, NODE_GEOMETRY, NODE_ORDER, NODE_FIELDS = 0, 1, 2, 3
DEFAULT_MAX_TETS = 1 << 27
PERMS = np.array(list(itertools.permutations(range(4))), dtype=np.int64)  # 24 row orders
ROWS = ("parity", "sorted", "oriented")


def row_convention(tets: np.ndarray, *, orient: bool = False) -> str:
    """How the rows of ``tets`` are ordered: ``"sorted"`` if every row ascends, else
    ``"parity"`` (``"oriented"`` when the caller turns tets by volume)."""
    if orient:
        return "oriented"
    t = np.asarray(tets)
    if len(t) and bool((t[:, 1:] > t[:, :-1]).all()):
        return "sorted"
    return "parity"


Progress = Callable[[int, int], None]


def compress_mesh(
    mesh: TetMesh,
    target: str | BinaryIO,
    *,
    bits: int = 16,
    lossless_geometry: bool = False,
    keep_order: bool = False,
    orient: bool = False,
    attr_error: dict[str, float] | None = None,
    force: bool = False,
    progress: Progress | None = None,
) -> dict[str, Any]:
    """Compress ``mesh`` into the ``.vpk`` file or binary stream ``target``.

    Parameters
    ----------
    bits : int
        Quantisation of the coordinates (bits over the bounding box diagonal).
    lossless_geometry : bool
        Keep the float coordinates bit for bit instead.
    keep_order : bool
        Also store the vertex, tet and row order so indices decode identically.
    orient : bool
        Give every tet of negative volume the opposite vertex order before coding, so a
        mesh without a consistent orientation (Delaunay's) codes no per-tet orientation
        (about a bit per tet less). With ``keep_order`` the rows still come back as given.
        Meshes whose rows all ascend (DOLFIN's) need no option: see the module docstring.
    attr_error : dict of str to float
        Per float field, the largest error allowed (the default keeps fields exactly).

    Returns
    -------
    dict
        Sizes and rates: ``bits_per_tet`` (connectivity), ``bits_per_vertex``
        (geometry), per-field ``bits_per_value`` and ``max_error``, ``tets_per_s``.
    """
    from ..format.container import Writer
    from . import attributes, cutborder, geometry

    validate(mesh)
    attr_error = dict(attr_error or {})
    names = set(mesh.point_data) | set(mesh.cell_data)
    unknown = sorted(set(attr_error) - names)
    if unknown:
        raise OptionError(
            f"attr_error names {unknown}, expected fields of the mesh: {sorted(names) or 'none'}"
        )
    t0 = time.perf_counter()
    nv, nt = mesh.n_vertices, mesh.n_tets
    steps = 3 + len(mesh.point_data) + len(mesh.cell_data)
    done = 0

    def tick():
        nonlocal done
        done += 1
        if progress is not None:
            progress(done, steps)

    tets = mesh.tets
    convention = row_convention(tets, orient=orient)
    if orient and nt:
        from .mesh import signed_volumes

        tets = tets.copy()
        flip = signed_volumes(mesh.points, tets) < 0
        tets[flip] = tets[flip][:, [1, 0, 2, 3]]
    conn, trav = cutborder.encode_connectivity(tets, nv, keep_orientation=convention != "sorted")
    t_conn = time.perf_counter() - t0
    tick()
    order = np.asarray(trav.vertex_order, dtype=np.int64)
    ctets = np.asarray(trav.tets, dtype=np.int64)
    t1 = time.perf_counter()
    geo, gmeta = geometry.encode_geometry(
        mesh.points[order], ctets, bits=bits, lossless=lossless_geometry,
        adjacency=trav.adjacency,
    )  # fmt: skip
    t_geo = time.perf_counter() - t1
    tick()
    geo_error = gmeta.pop("max_error")
    chunks = [(NODE_CONNECTIVITY, conn, 0.0), (NODE_GEOMETRY, geo, geo_error)]
    if keep_order:
        chunks.append((NODE_ORDER, _encode_order(mesh.tets, trav, convention == "sorted"), 0.0))
    tick()
    fields, summary_fields = [], {}
    prefs = np.asarray(trav.gates, dtype=np.int64)
    crefs = attributes.cell_refs(trav.tet_parent)
    tet_order = np.asarray(trav.tet_order, dtype=np.int64)
    node = NODE_FIELDS
    for where, data, rows, refs in (
        ("point", mesh.point_data, order, prefs),
        ("cell", mesh.cell_data, tet_order, crefs),
    ):
        for name, values in data.items():
            blob, meta = attributes.encode_attribute(
                values[rows], refs, max_error=attr_error.get(name)
            )
            err = meta.pop("max_error")
            fields.append({"name": name, "where": where, "node": node, **meta})
            chunks.append((node, blob, err))
            n = max(len(values), 1)
            summary_fields[f"{where}:{name}"] = {
                "nbytes": len(blob),
                "bits_per_value": 8 * len(blob) / n,
                "max_error": err,
                "mode": meta["mode"],
            }
            node += 1
            tick()
    header = {
        "kind": KIND_MESH,
        "format": FORMAT,
        "volpack": __version__,
        "vertices": nv,
        "tets": nt,
        "geometry": gmeta,
        "keep_order": bool(keep_order),
        "oriented": bool(orient),
        "rows": convention,
        "fields": fields,
    }
    sizes = {n: len(b) for n, b, _ in chunks}
    seconds = time.perf_counter() - t0
    summary = {
        "connectivity_nbytes": sizes[NODE_CONNECTIVITY],
        "geometry_nbytes": sizes[NODE_GEOMETRY],
        "order_nbytes": sizes.get(NODE_ORDER, 0),
        "bits_per_tet": 8 * sizes[NODE_CONNECTIVITY] / nt if nt else 0.0,
        "bits_per_vertex": 8 * sizes[NODE_GEOMETRY] / nv if nv else 0.0,
        "geometry_max_error": geo_error,
        "fields": summary_fields,
    }
    with Writer(target, header, force=force) as w:
        for n, blob, err in chunks:
            w.write(0, n, blob, error=err)
        w.close(summary)
    raw = mesh.points.nbytes + mesh.tets.astype(np.int32).nbytes
    raw += sum(v.nbytes for v in mesh.point_data.values())
    raw += sum(v.nbytes for v in mesh.cell_data.values())
    nbytes = sum(sizes.values())
    return {
        **summary,
        "vertices": nv,
        "tets": nt,
        "rows": convention,
        "geometry": dict(gmeta),
        "payload_nbytes": nbytes,
        "raw_nbytes": raw,
        "ratio": raw / max(nbytes, 1),
        "seconds": seconds,
        "connectivity_tets_per_s": nt / max(t_conn, 1e-9),
        "geometry_tets_per_s": nt / max(t_geo, 1e-9),
        "tets_per_s": nt / max(seconds, 1e-9),
    }


class MeshReader(CheckedReader):
    """A mesh ``.vpk`` opened for reading: the checked :attr:`header`, and :meth:`read`."""

    def __init__(self, source: Any, *, max_tets: int = DEFAULT_MAX_TETS) -> None:
        super().__init__(source, check_header, max_tets)
        self.max_tets = max_tets

    def read(self, progress: Progress | None = None) -> TetMesh:
        """Decode the mesh (see the module docstring for the order it comes in)."""
        from . import attributes, cutborder, geometry

        r, hdr, max_tets = self._r, self.header, self.max_tets
        nv, nt = hdr["vertices"], hdr["tets"]
        seekable = r.seekable
        cache = None if seekable else {n: p for _, n, p in r}

        def chunk(node: int) -> bytes:
            if seekable:
                if (0, node) not in r:
                    raise FormatError(f"mesh stream has no chunk {node}")
                return r.read(0, node)
            if node not in cache:
                raise FormatError(f"mesh stream has no chunk {node}")
            return cache.pop(node)

        steps = 2 + len(hdr["fields"])
        trav = cutborder.decode_connectivity(chunk(NODE_CONNECTIVITY), max_tets=max_tets)
        ctets = np.asarray(trav.tets, dtype=np.int64)
        if ctets.shape != (nt, 4) or len(trav.gates) != nv:
            raise FormatError(
                f"mesh stream: the connectivity holds {len(ctets)} tets and {len(trav.gates)} "
                f"vertices, the header says {nt} and {nv}"
            )
        if progress is not None:
            progress(1, steps)
        points = geometry.decode_geometry(chunk(NODE_GEOMETRY), hdr["geometry"], ctets, nv)
        if progress is not None:
            progress(2, steps)
        prefs = np.asarray(trav.gates, dtype=np.int64)
        crefs = attributes.cell_refs(trav.tet_parent)
        point_data, cell_data = {}, {}
        for i, f in enumerate(hdr["fields"]):
            point = f["where"] == "point"
            vals = attributes.decode_attribute(chunk(f["node"]), f, prefs if point else crefs)
            (point_data if point else cell_data)[f["name"]] = vals
            if progress is not None:
                progress(3 + i, steps)
        sort_rows = hdr["rows"] == "sorted"
        if hdr["keep_order"]:
            vorder, torder, perm = _decode_order(chunk(NODE_ORDER), nv, nt, not sort_rows)
            out_pts = np.empty_like(points)
            out_pts[vorder] = points
            tets = np.empty((nt, 4), dtype=np.int64)
            if sort_rows:
                tets[torder] = np.sort(vorder[ctets], axis=1)
            else:
                tets[torder] = np.take_along_axis(vorder[ctets], PERMS[perm], axis=1)
            for d, rows in ((point_data, vorder), (cell_data, torder)):
                for k, v in d.items():
                    o = np.empty_like(v)
                    o[rows] = v
                    d[k] = o
            return TetMesh(out_pts, tets, point_data, cell_data)
        if sort_rows:
            ctets = np.sort(ctets, axis=1)
        return TetMesh(points, ctets, point_data, cell_data)


def decompress_mesh(
    source: str | bytes | BinaryIO,
    *,
    max_tets: int = DEFAULT_MAX_TETS,
    progress: Progress | None = None,
) -> TetMesh:
    """Decode a mesh stream written by :func:`compress_mesh`."""
    with open(source, max_tets=max_tets) as r:
        return r.read(progress)


def open(source: Any, *, max_tets: int = DEFAULT_MAX_TETS) -> MeshReader:  # noqa: A001
    """Open a mesh ``.vpk`` (a path, ``'-'``, bytes, a binary file or a container Reader)."""
    if isinstance(source, str) and source == "-":
        from ..format.streams import stdin

        source = stdin()
    return MeshReader(source, max_tets=max_tets)


def compress(
    source: TetMesh | str,
    target: str | BinaryIO,
    *,
    tetrahedralize: bool = False,
    force: bool = False,
    **options: Any,
) -> dict[str, Any]:
    """Compress a mesh, or the mesh file ``source`` (read with meshio, hexahedra, wedges
    and pyramids split with ``tetrahedralize``; its warnings are issued as
    :class:`~volpack.tetra.formats.MeshWarning`), into ``target``; ``options`` as for
    :func:`compress_mesh`."""
    if isinstance(source, str):
        from ..format.atomic import check_output
        from .formats import read_mesh

        check_output(target, force=force, inputs=(source,))
        source = read_mesh(source, tetrahedralize=tetrahedralize)
    return compress_mesh(source, target, force=force, **options)


def decompress(
    source: Any, *, max_tets: int = DEFAULT_MAX_TETS, progress=None, **_: Any
) -> TetMesh:
    """Decode a mesh ``.vpk`` (as :func:`decompress_mesh`; ``'-'`` is standard input)."""
    with open(source, max_tets=max_tets) as r:
        return r.read(progress)


def info(source: str | BinaryIO) -> dict[str, Any]:
    """Describe a mesh ``.vpk`` (:func:`mesh_info`)."""
    return mesh_info(source)


def _get(d: Any, *keys: str) -> Any:
    """``d[k1][k2]...`` of a JSON summary, None where a level is missing or no object."""
    for k in keys:
        d = d.get(k) if isinstance(d, dict) else None
    return d


def mesh_info(source: str | BinaryIO) -> dict[str, Any]:
    """Describe a mesh ``.vpk`` (a path or a seekable binary file: sizes, bits per tet
    and per vertex, fields) as JSON types."""
    from ..format.container import Reader
    from ..format.streams import source_size

    with Reader(source) as r:
        hdr = check_header(r.header, DEFAULT_MAX_TETS)
        sizes = {e.node: e.nbytes for e in r.entries}
        summary = r.summary or {}
    nv, nt = hdr["vertices"], hdr["tets"]
    file_size = source_size(source)
    geo = hdr["geometry"]
    fields = {}
    for f in hdr["fields"]:
        n = nv if f["where"] == "point" else nt
        nb = sizes.get(f["node"], 0)
        fields[f"{f['where']}:{f['name']}"] = {
            "dtype": f["dtype"],
            "shape": f["shape"],
            "mode": f["mode"],
            "nbytes": nb,
            "bits_per_value": 8 * nb / n if n else 0.0,
            "max_error": _get(_get(summary, "fields"), f"{f['where']}:{f['name']}", "max_error"),
        }
    conn, gbytes = sizes.get(NODE_CONNECTIVITY, 0), sizes.get(NODE_GEOMETRY, 0)
    return {
        "format": "vpk",
        "kind": KIND_MESH,
        "path": source if isinstance(source, str) else "-",
        "header": hdr,
        "vertices": nv,
        "tets": nt,
        "file_nbytes": file_size,
        "connectivity_nbytes": conn,
        "geometry_nbytes": gbytes,
        "order_nbytes": sizes.get(NODE_ORDER, 0),
        "bits_per_tet": 8 * conn / nt if nt else 0.0,
        "bits_per_vertex": 8 * gbytes / nv if nv else 0.0,
        "geometry": {
            "mode": geo["mode"],
            "dtype": geo["dtype"],
            "bits": geo.get("bits"),
            "max_error": _get(summary, "geometry_max_error"),
        },
        "keep_order": hdr["keep_order"],
        "rows": hdr["rows"],
        "fields": fields,
    }


def check_header(hdr: dict, max_tets: int = DEFAULT_MAX_TETS) -> dict:
    """Validate a mesh header (kind, counts within limits, fields); return it."""
    from ..format import header as h
    from .geometry import MODES

    if hdr.get("kind") != KIND_MESH:
        raise FormatError(
            f"expected a volpack mesh header (kind 'mesh'), found kind {hdr.get('kind')!r}"
        )
    try:
        nv, nt = int(hdr["vertices"]), int(hdr["tets"])
        geo = dict(hdr["geometry"])
        if not isinstance(geo["mode"], str) or geo["mode"] not in MODES:
            raise ValueError(f"geometry mode {geo['mode']!r}")
        h.dtype(geo["dtype"], "geometry dtype", "f")
        fields = [dict(f) for f in hdr["fields"]]
        for f in fields:
            if f["where"] not in ("point", "cell") or not isinstance(f["name"], str):
                raise ValueError(f)
            if f["mode"] not in ("exact", "bounded") or not isinstance(f["shape"], list):
                raise ValueError(f)
            h.dtype(f["dtype"], "field dtype")
            f["node"] = int(f["node"])
        keep = bool(hdr.get("keep_order", False))
        rows = str(hdr.get("rows", "oriented" if hdr.get("oriented") else "parity"))
    except (KeyError, TypeError, ValueError, OverflowError) as e:  # FormatError is a ValueError
        raise FormatError(f"bad mesh header: {e}") from None
    if rows not in ROWS:
        raise FormatError(f"bad mesh header: rows {rows!r}, expected one of {list(ROWS)}")
    if hdr.get("format") != FORMAT:
        raise FormatError(f"expected mesh stream format {FORMAT!r}, found {hdr.get('format')!r}")
    if nt < 0 or nv < 0 or nt > max_tets or nv > 4 * max_tets:
        raise LimitError(
            f"mesh of {nv} vertices and {nt} tets exceeds the limit of {max_tets} tets"
        )
    return {
        **hdr,
        "vertices": nv,
        "tets": nt,
        "geometry": geo,
        "fields": fields,
        "keep_order": keep,
        "rows": rows,
    }


# --- the input order (keep_order) -------------------------------------------------------


def _encode_order(tets: np.ndarray, trav, sorted_rows: bool = False) -> bytes:
    """Vertex order, tet order and each row's vertex order (an index into PERMS), zstd'd.

    Ascending rows need no row order: the decoder sorts them."""
    from ..format.deflate import deflate

    vorder = np.asarray(trav.vertex_order, dtype=np.int64)
    torder = np.asarray(trav.tet_order, dtype=np.int64)
    width = "<u4" if len(vorder) < 1 << 32 and len(torder) < 1 << 32 else "<u8"
    raw = vorder.astype(width).tobytes() + torder.astype(width).tobytes()
    if not sorted_rows:
        decoded = vorder[np.asarray(trav.tets, dtype=np.int64)]  # coded rows, input ids
        wanted = tets[torder]
        perm = np.full(len(torder), -1, dtype=np.int64)
        for i, p in enumerate(PERMS):
            hit = (perm < 0) & (decoded[:, p] == wanted).all(axis=1)
            perm[hit] = i
        if (perm < 0).any():
            raise AssertionError("a decoded tet row is no permutation of its input row")
        raw += perm.astype(np.uint8).tobytes()
    return deflate(raw)


def _decode_order(
    blob: bytes, nv: int, nt: int, with_rows: bool = True
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    from ..format.deflate import inflate

    width = 4 if nv < 1 << 32 and nt < 1 << 32 else 8
    need = width * (nv + nt) + (nt if with_rows else 0)
    raw = inflate(blob, need, "mesh order chunk", exact=True)
    dt = f"<u{width}"
    vorder = np.frombuffer(raw, dtype=dt, count=nv).astype(np.int64)
    torder = np.frombuffer(raw, dtype=dt, count=nt, offset=width * nv).astype(np.int64)
    perm = np.frombuffer(
        raw, dtype=np.uint8, count=nt if with_rows else 0, offset=width * (nv + nt)
    ).astype(np.int64)
    for name, o, n in (("vertex", vorder, nv), ("tet", torder, nt)):
        if n and not np.array_equal(np.sort(o), np.arange(n)):
            raise FormatError(f"corrupt mesh order chunk: the {name} order is no permutation")
    if (perm >= len(PERMS)).any():
        raise FormatError("corrupt mesh order chunk: a row order index exceeds 23")
    return vorder, torder, perm
