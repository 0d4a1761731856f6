"""The tetrahedral-mesh side of ``volpack compress``, ``decompress`` and ``info``.

``compress`` sends inputs with a mesh suffix (:data:`volpack.tetra.MESH_EXTENSIONS`)
here; ``decompress`` and ``info`` send ``.vpk`` files whose header says
``kind: "mesh"``, and ``info`` mesh files too. Only click and the light
:mod:`volpack.tetra` package are imported at the top.
"""

from __future__ import annotations

import contextlib
import time
import warnings

import click

from .options import emit_json, fmt_bytes, option, options

_ROWS = {
    "parity": "each row's orientation kept",
    "sorted": "ascending (as in the input; orientation not coded)",
    "oriented": "turned to positive volume (--orient)",
}


def _attr_error(values: tuple[str, ...]) -> dict[str, float]:
    out = {}
    for v in values:
        name, sep, err = v.rpartition("=")
        try:
            out[name] = float(err)
            if not sep or not name or out[name] < 0:
                raise ValueError
        except ValueError:
            raise click.BadParameter(
                f"expected NAME=ERROR with ERROR >= 0, found {v!r}", param_hint="--attr-error"
            ) from None
    return out


mesh_options = options(
    option("--bits", "Mesh: quantise vertex coordinates to this many bits of the bounding box "
           "diagonal.", (1, 30), 16),
    option("--lossless-geometry", "Mesh: keep the float vertex coordinates bit for bit.", bool),
    option("--keep-order", "Mesh: also store the vertex and tet order, so indices decode "
           "identically.", bool),
    option("--orient", "Mesh: turn inverted tets to positive volume before coding (about a "
           "bit per tet less on meshes without a consistent orientation, e.g. Delaunay's; "
           "--keep-order still restores the rows as given). Not needed when every row ascends "
           "(DOLFIN's): such rows are detected and decode ascending.", bool),
    option("--tetrahedralize", "Mesh: split hexahedra, wedges and pyramids into tetrahedra "
           "(no new vertices).", bool),
    option("--attr-error", "Mesh: code the float field NAME within absolute error E (default: "
           "exactly). Repeatable.", multiple=True, metavar="NAME=E"),
)  # fmt: skip
"""The mesh-only options of ``volpack compress``."""


def is_mesh_source(path: str) -> bool:
    from ..tetra import is_mesh_path

    return path != "-" and is_mesh_path(path)


def is_mesh_stream(path: str) -> bool:
    """True for a ``.vpk`` file whose header says ``kind: "mesh"``."""
    from ..format.streams import vpk_kind

    return vpk_kind(path) == "mesh"


MESH_KEYS = ("bits", "lossless_geometry", "keep_order", "orient", "tetrahedralize", "attr_error")


def compress_options(extra: dict) -> dict:
    """The mesh options of ``volpack compress`` as :func:`volpack.tetra.stream.compress`
    takes them."""
    opts = {k: extra[k] for k in MESH_KEYS}
    opts["attr_error"] = _attr_error(opts["attr_error"])
    return opts


@contextlib.contextmanager
def echo_warnings():
    """Print the library's warnings (e.g. meshio's) as ``volpack: warning:`` lines."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            yield
        finally:
            for w in caught:
                click.echo(f"volpack: warning: {w.message}", err=True)


def mesh_line(target: str, stats: dict) -> str:
    """The line ``volpack compress`` prints for a mesh."""
    g = stats["geometry"]
    geo = (
        "lossless"
        if g["mode"].startswith("lossless")
        else f"{g['bits']}-bit, max error {stats['geometry_max_error']:.3g}"
    )
    return (
        f"{target}: {fmt_bytes(stats['payload_nbytes'])} from {fmt_bytes(stats['raw_nbytes'])} "
        f"(ratio {stats['ratio']:.2f}:1); {stats['vertices']} vertices, {stats['tets']} tets; "
        f"connectivity {stats['bits_per_tet']:.2f} bits/tet, geometry "
        f"{stats['bits_per_vertex']:.2f} bits/vertex ({geo}); "
        f"{stats['tets_per_s'] / 1e3:.0f}k tets/s"
    )


def decompress(source: str, target: str, *, force: bool, as_json: bool) -> None:
    """Decode the mesh .vpk SOURCE into the mesh file TARGET (format by suffix)."""
    from .. import api
    from ..format.atomic import check_output
    from ..tetra.formats import write_mesh

    check_output(target, force=force, inputs=(source,))
    t0 = time.perf_counter()
    mesh = api.decompress(source)
    seconds = time.perf_counter() - t0
    write_mesh(mesh, target, force=force)
    stats = {
        "target": target,
        "vertices": mesh.n_vertices,
        "tets": mesh.n_tets,
        "point_data": sorted(mesh.point_data),
        "cell_data": sorted(mesh.cell_data),
        "seconds": seconds,
        "tets_per_s": mesh.n_tets / max(seconds, 1e-9),
    }
    if as_json:
        emit_json(stats)
    else:
        click.echo(
            f"{target}: {mesh.n_vertices} vertices, {mesh.n_tets} tets, "
            f"{stats['tets_per_s'] / 1e3:.0f}k tets/s",
            err=True,
        )


def show_info(d: dict, as_json: bool) -> None:
    """Print what ``volpack info`` says of a mesh .vpk or a mesh file."""
    if as_json:
        emit_json(d)
        return
    click.echo(_human(d))


def _human(d: dict) -> str:
    if d["format"] == "vpk":
        g = d["geometry"]
        geo = (
            "lossless"
            if g["mode"].startswith("lossless")
            else f"{g['bits']}-bit, max error {g['max_error']:.3g}"
        )
        rows = [
            ["path", d["path"]],
            ["format", f"vpk (kind mesh, written by volpack {d['header'].get('volpack', '?')})"],
            ["vertices", str(d["vertices"])],
            ["tets", str(d["tets"])],
            ["size", fmt_bytes(d["file_nbytes"])],
            [
                "connectivity",
                f"{fmt_bytes(d['connectivity_nbytes'])}, {d['bits_per_tet']:.3f} bits/tet",
            ],
            [
                "geometry",
                f"{fmt_bytes(d['geometry_nbytes'])}, {d['bits_per_vertex']:.3f} bits/vertex ({geo}, {g['dtype']})",
            ],
            ["order", "kept" if d["keep_order"] else "coding order (not kept)"],
            ["rows", _ROWS[d["rows"]]],
        ]
        for name, f in d["fields"].items():
            err = "exact" if f["mode"] == "exact" else f"max error {f['max_error']:.3g}"
            rows.append(
                [
                    name,
                    f"{f['dtype']} {f['shape']}, {fmt_bytes(f['nbytes'])}, {f['bits_per_value']:.3f} bits/value ({err})",
                ]
            )
        return "\n".join(f"{k:<14} {v}" for k, v in rows)
    keys = [
        "vertices", "tets", "edges", "faces", "border_faces", "border_vertices", "euler",
        "components", "zero_volume", "inverted", "negative_volume", "unreferenced_vertices",
        "duplicate_vertices", "nonmanifold_faces", "nonmanifold_edges", "nonmanifold_vertices",
    ]  # fmt: skip
    rows = [["path", d["path"]], ["format", "mesh (read with meshio)"]]
    rows += [[k.replace("_", " "), str(d[k])] for k in keys]
    for where in ("point_data", "cell_data"):
        for name, f in d[where].items():
            rows.append([f"{where.split('_')[0]}:{name}", f"{f['dtype']} {f['shape']}"])
    rows += [["warning", w] for w in d.get("warnings", [])]
    return "\n".join(f"{k:<22} {v}" for k, v in rows)
