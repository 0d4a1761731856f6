"""``volpack info a b c``: one line per file, from headers only (as ``nib-ls``)."""

from __future__ import annotations

from typing import Any

from .options import dtype_name, fmt_bytes, table


def listing(sources, raw: dict) -> list[dict[str, Any]]:
    """One dict per source: path, format, shape, dtype, spacing, nbytes, ratio, max_error,
    or the error that kept it from being read (the others are still listed)."""
    from .. import io as vio
    from ..errors import VolpackError
    from . import mesh as mesh_cli

    rows = []
    for src in sources:
        row: dict[str, Any] = {"path": src}
        try:
            if mesh_cli.is_mesh_source(src) or mesh_cli.is_mesh_stream(src):
                row["format"] = "mesh"
            elif vio.detect_format(vio.parse_spec(src)[0]) == "vpk" and not raw:
                from .. import api

                d = api.info(src)
                h = d["header"]
                row.update(
                    format=f"vpk/{h.get('kind', 'volume')}",
                    shape=h.get("shape"),
                    dtype=dtype_name(h.get("dtype")),
                    spacing=h.get("spacing"),
                    nbytes=d["file_nbytes"],
                    ratio=d["ratio"],
                    max_error=d["max_error"],
                )
            else:
                h = vio.read_header(src, **raw)
                row.update({k: h[k] for k in ("format", "shape", "spacing")})
                row["dtype"] = dtype_name(h["dtype"])
        except (VolpackError, OSError, ValueError) as e:
            row["error"] = str(e)
        rows.append(row)
    return rows


def listing_table(rows: list[dict[str, Any]]) -> str:
    def cell(r, key, fmt):
        v = r.get(key)
        return "-" if v is None else fmt(v)

    out = [
        [
            r["path"],
            r.get("format", "error"),
            cell(r, "shape", lambda s: "x".join(map(str, s))),
            cell(r, "dtype", str),
            cell(r, "spacing", lambda s: ",".join(f"{v:g}" for v in s)),
            cell(r, "nbytes", fmt_bytes),
            cell(r, "ratio", lambda v: f"{v:.3f}"),
            cell(r, "max_error", lambda v: f"{v:g}"),
        ]
        for r in rows
    ]
    text = table(
        out, ["file", "format", "shape (z,y,x)", "dtype", "spacing", "size", "ratio", "max error"]
    )
    errors = [f"{r['path']}: {r['error']}" for r in rows if "error" in r]
    return text + ("\n" + "\n".join(errors) if errors else "")
