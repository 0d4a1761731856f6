"""``volpack info``: what a file holds."""

from __future__ import annotations

import click

from ..errors import FormatError
from .listing import listing_table
from .options import db, dtype_name, emit_json, fmt_bytes, json_option, raw_options, table


@click.command(context_settings={"help_option_names": ["-h", "--help"]})
@click.argument("sources", nargs=-1, required=True, metavar="SOURCE...")
@json_option
@click.option(
    "--chunks", is_flag=True, help="For .vpk: list every chunk (t, node, offset, bytes, error)."
)
@click.option(
    "--levels", is_flag=True, help="For an octree .vpk: nodes, bytes and errors per level."
)
@raw_options
def info(sources, as_json: bool, chunks: bool, levels: bool, read_options) -> None:
    """Describe SOURCE: a .vpk file or any volume volpack reads; several: one table.

    \b
    For a volume: format, shape (z, y, x), dtype, spacing, value range, size.
    For a .vpk: its header, chunk count, sizes, ratio and per-chunk error.
    For several files: one line each (format, shape, dtype, spacing, size, ratio, max
    error), read from the headers only, as nib-ls does.

    \b
    Examples:
      volpack info head.nii.gz
      volpack info ct.vpk --json | jq .ratio
      volpack info scan.raw --shape 108,256,256 --dtype int16
      volpack info big.vpk --levels
      volpack compress ct.nii.gz - | volpack info -
      volpack info scans/*.nii.gz out/*.vpk
      volpack info era5.nc                  a file of several variables: lists them
    """
    if len(sources) > 1:
        from .listing import listing

        rows = listing(sources, read_options)
        if as_json:
            emit_json(rows)
        else:
            click.echo(listing_table(rows))
        if any("error" in r for r in rows):
            raise SystemExit(1)  # every file listed; the status says one could not be read
        return
    (source,) = sources
    if levels:
        from .octree import levels as octree_levels

        octree_levels(source, as_json)
        return
    from .. import api

    if source == "-" and api.kind_of("-") is not None:
        from ..format.streams import spool, stdin

        with spool(stdin()) as f:  # a .vpk on a pipe: its index comes last, so keep it whole
            return _show(api.info(f), as_json, chunks)
    try:
        d = api.info(source, **read_options)
    except FormatError:
        found = _arrays(source)
        if found is None:
            raise
        return _show_arrays(source, found, as_json)
    _show(d, as_json, chunks)


def _arrays(source: str) -> list[dict] | None:
    """The arrays of an HDF5, netCDF or zarr file that names none of its several
    arrays (so that ``info`` lists them rather than fail), else None."""
    from .. import io as vio

    if source == "-" or vio.parse_spec(source)[1] is not None:
        return None
    try:
        found = vio.list_arrays(source)
    except FormatError:
        return None
    return found if len(found) > 1 else None


def _show_arrays(source: str, found: list[dict], as_json: bool) -> None:
    from .. import io as vio

    fmt = vio.detect_format(source)
    if as_json:
        emit_json({"path": source, "format": fmt, "arrays": found})
        return
    click.echo(f"{'path':<12} {source}\n{'format':<12} {fmt}")
    click.echo(f"{'arrays':<12} {len(found)}; name one to read it: {source}:NAME")
    rows = [[a["name"], " x ".join(map(str, a["shape"])) or "scalar", a["dtype"]] for a in found]
    click.echo(table(rows, ["name", "shape", "dtype"]))


def _show(d: dict, as_json: bool, chunks: bool) -> None:
    try:
        _show_as(d, as_json, chunks)
    except (TypeError, AttributeError, ValueError, KeyError, IndexError) as e:
        # The text view formats what the header and summary say; a damaged file's field of
        # another type (a list for a number, a number for a dict) must not be a crash.
        raise FormatError(
            f"{d.get('path', '-')}: expected header and summary fields of the types volpack "
            f"writes, found another ({type(e).__name__}: {e}); the file is damaged "
            "(`volpack info --json` shows its fields as stored)"
        ) from None


def _show_as(d: dict, as_json: bool, chunks: bool) -> None:
    if d["format"] == "mesh" or d.get("kind") == "mesh":
        from .mesh import show_info

        return show_info(d, as_json)
    if not (as_json and chunks) and "entries" in d and not chunks:
        d = {k: v for k, v in d.items() if k != "entries"}
    if as_json:
        emit_json(d)
        return
    click.echo(_human(d, chunks))


def _axes(shape: list[int]) -> str:
    """The axes of a source volume's shape as `compress` takes them."""
    from ..volume_codec.channels import looks_channels_last

    if len(shape) != 4:
        return "(z, y, x)"
    if looks_channels_last(tuple(shape)):
        return "(z, y, x, c): channels, as compress takes them (--no-channels-last: t, z, y, x)"
    return "(t, z, y, x)"


def _tuples_row(spec: dict) -> str:
    """The channels row of a volume stored as a tuple palette (its header checked)."""
    axes = "(z, y, x, c)" if spec["axis"] == "last" else "(c, z, y, x)"
    return (
        f"{spec['axis']}: {axes}, stored as a palette of {spec['tuples']} voxel tuples "
        "(chunk 1, 0) and a volume of indices into it"
    )


def _number(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def _readable_summary(s) -> dict:
    """The summary fields the text view shows, each of the type the encoder writes: the
    summary is what the encoder measured, checked by no decoder, so a damaged file's
    field of another type is left out (shown as unknown), not formatted into a crash."""
    if not isinstance(s, dict):
        return {}
    out = {k: s[k] for k in ("error_bound", "psnr", "rmse", "max_error") if _number(s.get(k))}
    if isinstance(s.get("lossless"), bool):
        out["lossless"] = s["lossless"]
    for k in ("psnr", "rmse"):
        if k in s and k not in out:
            out[k] = None  # present but unreadable: None reads "unknown"
    tools = s.get("tools")
    if isinstance(tools, dict) and all(_number(v) for v in tools.values()):
        out["tools"] = tools
    q = s.get("search")
    if (
        isinstance(q, dict)
        and isinstance(q.get("target"), str)
        and _number(q.get("value"))
        and (q.get("reached") is None or _number(q.get("reached")))
    ):
        out["search"] = q
    return out


def _human(d: dict, chunks: bool) -> str:
    if d["format"] != "vpk":
        rows = [
            ["path", d["path"]],
            ["format", d["format"]],
            ["shape", " x ".join(map(str, d["shape"])) + "  " + _axes(d["shape"])],
            ["dtype", d["dtype"]],
            ["spacing", ", ".join(f"{s:g}" for s in d["spacing"])],
            ["value range", f"{d['min']} .. {d['max']}"],
            ["size", fmt_bytes(d["nbytes"])],
        ]
        for k in ("nan", "inf", "masked"):
            if d.get(k):
                rows.append([k, str(d[k])])
        for k, v in (d.get("meta") or {}).items():
            rows.append([f"meta.{k}", str(v)])
        return "\n".join(f"{k:<12} {v}" for k, v in rows)
    h = d["header"]
    s = _readable_summary(d.get("summary"))
    rows = [
        ["path", d["path"]],
        [
            "format",
            f"vpk {d.get('vpk_version', 1)} (kind {h.get('kind')}, written by volpack "
            f"{h.get('volpack', '?')})",
        ],
        ["shape", " x ".join(map(str, h.get("shape", [])))],
        ["dtype", dtype_name(h.get("dtype"))],
        ["spacing", ", ".join(f"{v:g}" for v in h.get("spacing", []))],
        ["codec", ", ".join(f"{k}={v}" for k, v in (h.get("codec") or {}).items())],
        *(
            [["motion", ", ".join(f"{k}={v}" for k, v in h["motion"].items())]]
            if isinstance(h.get("motion"), dict)
            else []
        ),
        *(
            [["channels", "last: (z, y, x, c), stored as the series of its channels"]]
            if h.get("channels") == "last"
            else []
        ),
        *(
            [["channels", _tuples_row(h["channels"])]]
            if isinstance(h.get("channels"), dict)
            else []
        ),
        *(
            [["layout", "time steps interleaved: slices stored in (z, t) order"]]
            if h.get("layout") == "interleaved"
            else []
        ),
        ["bricks", f"{d['chunks']} chunks of up to {'x'.join(map(str, h.get('brick', [])))}"],
        *(
            [["tools", ", ".join(f"{k} {v}" for k, v in s["tools"].items()) + " (bricks)"]]
            if isinstance(s.get("tools"), dict)
            else []
        ),
        ["size", f"{fmt_bytes(d['file_nbytes'])} (raw {fmt_bytes(d['raw_nbytes'])})"],
        [
            "ratio",
            f"{d['ratio']:.3f} : 1  ({8 * d['file_nbytes'] / max(1, d['raw_nbytes'] // max(1, _itemsize(h))):.3f} bits/voxel)",
        ],
        [
            "chunk bytes",
            f"min {d['chunk_nbytes']['min']}, mean {d['chunk_nbytes']['mean']:.0f}, max {d['chunk_nbytes']['max']}",
        ],
        ["max error", "0 (lossless)" if s.get("lossless") else f"{d['max_error']:g}"],
    ]
    if not s.get("lossless", True):
        if s.get("error_bound") is not None:
            rows.append(
                [
                    "error bound",
                    f"{s['error_bound']:g} (held on every voxel; NaN, Inf and the fill value exact)",
                ]
            )
        rows.append(["PSNR", db(s.get("psnr"), s.get("max_error"))])
        rmse = s.get("rmse", 0.0)
        rows.append(["RMSE", "unknown" if rmse is None else f"{rmse:g}"])
        if s.get("search"):
            q = s["search"]
            got = "coded exactly" if q["reached"] is None else f"reached {q['reached']:.4g}"
            rows.append(["target", f"{q['target']} {q['value']:g}: {got}"])
    out = "\n".join(f"{k:<12} {v}" for k, v in rows)
    if h.get("kind") == "animation":
        from .animation import frame_table

        out += "\n\n" + frame_table(d)
    if chunks:
        trs = [
            [str(e["t"]), str(e["node"]), str(e["offset"]), str(e["nbytes"]), f"{e['error']:g}"]
            for e in d["entries"]
        ]
        out += "\n\n" + table(trs, ["t", "node", "offset", "bytes", "error"])
    return out


def _itemsize(h: dict) -> int:
    import numpy as np

    try:
        return np.dtype(h.get("dtype", "u1")).itemsize
    except TypeError:
        return 1


COMMANDS = [info]
