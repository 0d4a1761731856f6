"""The octree side of ``volpack compress --octree``, ``decompress --level/--error`` and
``info --levels``: the lines and the table they print (the library is
:mod:`volpack.octree.stream`)."""

from __future__ import annotations

import click

from .options import emit_json, fmt_bytes, fmt_speed, plural, table


def octree_line(target: str, stats: dict) -> str:
    """The line ``volpack compress --octree`` prints."""
    acc = "lossless"
    if not stats["lossless"]:
        psnr = "inf" if stats["psnr"] is None else f"{stats['psnr']:.2f}"
        acc = f"max error {stats['max_error']:g} (bound {stats['error_bound']:g}), PSNR {psnr} dB"
    return (
        f"{target}: octree of depth {stats['depth']} ({stats['block']}^3 nodes), "
        f"{fmt_bytes(stats['payload_nbytes'])} from {fmt_bytes(stats['raw_nbytes'])}, "
        f"ratio {stats['ratio']:.3f}:1, {acc}, "
        f"{fmt_speed(stats['mb_per_s'], stats['seconds'])}"
    )


def octree_decoded_line(target: str, stats: dict) -> str:
    """The line ``volpack decompress --level/--error`` prints."""
    levels = stats["levels"]
    return (
        f"{target}: {'x'.join(map(str, stats['shape']))} {stats['dtype']} from "
        f"{plural('level', len(levels))} {','.join(map(str, levels))}, read "
        f"{fmt_bytes(stats['bytes_read'])}, {stats['nodes_decoded']} nodes decoded, "
        f"{stats['seconds']:.2f} s"
    )


def levels(source: str, as_json: bool) -> None:
    """Print nodes, bytes and errors per level of an octree (from its index only)."""
    from ..octree.stream import levels as octree_levels

    out = octree_levels(source)
    if as_json:
        emit_json(out)
        return
    trs = [
        [
            str(r["level"]),
            "x".join(map(str, r["shape"])),
            str(r["nodes"]),
            str(r["chunks"]),
            fmt_bytes(r["nbytes"]),
            f"{r['max_deviation']:g}",
            f"{r['E_max']:.4g}",
        ]
        for r in out["levels"]
    ]
    click.echo(table(trs, ["level", "shape", "nodes", "chunks", "bytes", "max dev", "E max"]))
