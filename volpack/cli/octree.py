"""The octree side of ``volpack compress --octree``, ``decompress --level/--error`` and
``info --levels`` (the shared commands call in here)."""

from __future__ import annotations

import time

import click

from .options import emit_json, fmt_bytes, progress_bar, table


def is_octree(path: str) -> bool:
    """True when ``path`` is a ``.vpk`` of kind octree (reads only the header)."""
    if path == "-":
        return False
    from ..format.container import Reader, is_vpk

    try:
        with open(path, "rb") as f:
            if not is_vpk(f.read(16)):
                return False
        with Reader(path) as r:
            return r.header.get("kind") == "octree"
    except (OSError, ValueError):
        return False


REFUSED = ("rel_error", "psnr", "ratio", "quality", "threshold", "fill_value")


def compress(ctx, read_options: dict) -> None:
    """Build the octree of SOURCE into TARGET (``ctx.params`` of ``volpack compress``),
    reading SOURCE box by box."""
    from ..format.atomic import check_output
    from ..io import parse_spec
    from ..octree import build
    from ..octree.source import SourceSpec

    p = ctx.params
    refused = ["--" + k.replace("_", "-") for k in REFUSED if p.get(k) is not None]
    if refused:
        raise click.UsageError(
            f"--octree takes --max-error or nothing (lossless), found {', '.join(refused)}"
        )
    source, target, force = p["source"], p["target"], p["force"]
    if target == "-":
        raise click.UsageError("--octree writes a seekable file, not '-'")
    check_output(target, force=force, inputs=(parse_spec(source)[0],))
    spec = SourceSpec(source, tuple(sorted(read_options.items())))
    with progress_bar(ctx, "octree", unit="super-brick") as progress:
        stats = build(
            spec,
            target,
            **{k: p[k] for k in ("block", "wavelet", "coder", "order", "max_error", "workers")},
            scheduler=p["scheduler"],
            force=force,
            progress=progress,
        )
    if p["as_json"]:
        emit_json(stats)
        return
    acc = "lossless"
    if not stats["lossless"]:
        psnr = "inf" if stats["psnr"] is None else f"{stats['psnr']:.2f}"
        acc = f"max error {stats['max_error']:g} (bound {stats['error_bound']:g}), PSNR {psnr} dB"
    click.echo(
        f"{target}: octree of depth {stats['depth']} ({stats['block']}^3 nodes), "
        f"{fmt_bytes(stats['payload_nbytes'])} from {fmt_bytes(stats['raw_nbytes'])}, "
        f"ratio {stats['ratio']:.3f}:1, {acc}, {stats['mb_per_s']:.1f} MB/s",
        err=True,
    )


def decompress(ctx, source, target, *, roi, level, error, force, as_json, workers=1) -> None:
    """Decode an octree at one level, or the coarsest nodes within an error bound."""
    from .. import io as vio
    from ..format.atomic import check_output
    from ..octree import Octree
    from ..octree.select import by_error

    check_output(vio.parse_spec(target)[0], force=force, inputs=(source,))
    t0 = time.perf_counter()
    with Octree(source) as tree:
        if error is not None:
            if level is not None:
                raise click.UsageError("give --level or --error, not both")
            sel = by_error(tree, error, roi)
            vol = tree.assemble(sel, level=0, roi=roi, interp="nearest")
            levels = sorted({lv for lv, _ in sel})
        else:
            vol = tree.decode(level or 0, roi, workers=workers)
            levels = [level or 0]
        bytes_read = tree.bytes_read
        nodes = tree.decoded_nodes
    seconds = time.perf_counter() - t0
    vio.write_volume(vol, target, force=force)
    stats = {
        "target": target,
        "shape": list(vol.shape),
        "dtype": str(vol.dtype),
        "levels": levels,
        "bytes_read": bytes_read,
        "nodes_decoded": nodes,
        "seconds": seconds,
    }
    if as_json:
        emit_json(stats)
    elif target != "-":
        click.echo(
            f"{target}: {'x'.join(map(str, vol.shape))} {vol.dtype} from level"
            f"{'s' if len(levels) > 1 else ''} {','.join(map(str, levels))}, read "
            f"{fmt_bytes(bytes_read)}, {nodes} nodes decoded, {seconds:.2f} s",
            err=True,
        )


def levels(source: str, as_json: bool) -> None:
    """Print nodes, bytes and errors per level of an octree (from its index only)."""
    from ..octree import Octree

    with Octree(source) as tree:
        rows = []
        for lv in range(tree.depth, -1, -1):
            t = tree.table(lv)
            n = tree.geometry.level_shape(lv)
            per = next((p for p in tree.summary.get("levels", []) if p["level"] == lv), {})
            rows.append(
                {
                    "level": lv,
                    "shape": list(n),
                    "nodes": int(t.size),
                    "chunks": int(per.get("chunks", 0)),
                    "nbytes": int(per.get("nbytes", 0)),
                    "max_deviation": float(t["maxdev"].max(initial=0.0)),
                    "E_max": float(t["E"].max(initial=0.0)),
                    "stripped": int(((t["flags"] & 1) == 0).sum()) if lv > 0 else None,
                }
            )
        out = {"path": source, "depth": tree.depth, "block": tree.plan.block, "levels": rows}
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
        for r in rows
    ]
    click.echo(table(trs, ["level", "shape", "nodes", "chunks", "bytes", "max dev", "E max"]))
