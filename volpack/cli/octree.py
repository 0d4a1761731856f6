"""The octree side of ``volpack compress --octree``, ``decompress --level/--error`` and
``info --levels``: the lines and the table they print (the library is
:mod:`volpack.octree.stream`)."""

from __future__ import annotations

import click

from .options import accuracy, emit_json, fmt_bytes, fmt_speed, plural, sizes, table


def octree_line(target: str, stats: dict) -> str:
    """The line ``volpack compress --octree`` prints."""
    return (
        f"{target}: octree of depth {stats['depth']} ({stats['block']}^3 nodes), "
        f"{sizes(stats['payload_nbytes'], stats['raw_nbytes'], stats['ratio'])}, "
        f"{accuracy(stats, stats.get('error_bound'))}, "
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
