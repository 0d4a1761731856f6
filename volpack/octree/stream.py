"""The octree stream kind: :func:`compress` builds an octree ``.vpk`` (a file read box by
box, so it may be larger than memory), :func:`open` gives the :class:`~volpack.octree.Octree`
reader, :func:`decompress` decodes one level or the coarsest nodes within an error,
:func:`levels` lists what each level holds (from the index alone)."""

from __future__ import annotations

import time
from typing import Any, BinaryIO, NamedTuple

from ..errors import FormatError, OptionError
from ..format.describe import describe
from ..volume import Volume
from . import layout
from .reader import Octree

KIND = layout.KIND
REFUSED = ("rel_error", "psnr", "ratio", "quality", "threshold", "fill_value")


def compress(
    source: Any,
    target: str,
    *,
    force: bool = False,
    read_options: dict | None = None,
    **options: Any,
) -> dict[str, Any]:
    """Build the octree of ``source`` (an array, a Volume, or a volume file spec read box
    by box with ``read_options``) into the seekable file ``target``; ``options`` are those
    of :func:`volpack.octree.builder.build`, which lists them and the returned summary.
    Lossless, or within ``max_error``: the other lossy settings are refused."""
    import inspect

    from ..format.atomic import check_output
    from .builder import build

    accepted = set(inspect.signature(build).parameters) - {"source", "target", "force"}
    given = [k for k in REFUSED if options.get(k) is not None]
    unknown = sorted(set(options) - accepted - set(REFUSED))
    if unknown:
        raise TypeError(f"compress() of an octree got unexpected options {unknown}")
    if given:
        raise OptionError(f"octrees take max_error or nothing (lossless), found {', '.join(given)}")
    if target == "-":
        raise OptionError("an octree is written to a seekable file, not '-'")
    if isinstance(source, str):
        from ..io import parse_spec
        from .source import SourceSpec

        check_output(target, force=force, inputs=(parse_spec(source)[0],))
        source = SourceSpec(source, tuple(sorted((read_options or {}).items())))
    kept = {k: v for k, v in options.items() if k in accepted}  # the refused ones are None
    return build(source, target, force=force, **kept)


def open(source: Any, **options: Any) -> Octree:  # noqa: A001
    """Open an octree ``.vpk`` (a path, bytes or a seekable binary file)."""
    return Octree(source, **options)


class Decoded(NamedTuple):
    """What :func:`decode` returns: the volume, the levels it came from, and its cost."""

    volume: Volume
    levels: list[int]
    bytes_read: int
    nodes_decoded: int
    seconds: float


def decode(
    source: Any,
    *,
    level: int | None = None,
    error: float | None = None,
    roi: str | tuple[slice, ...] | None = None,
    workers: int | None = 1,
) -> Decoded:
    """Decode an octree at ``level`` (1/2^level resolution per axis), or the coarsest
    nodes whose voxels deviate at most ``error`` (assembled at full resolution), inside
    ``roi``; reads only the nodes needed."""
    from .select import by_error

    if error is not None and level is not None:
        raise OptionError("expected level or error, found both")
    t0 = time.perf_counter()
    with Octree(source) as tree:
        if error is not None:
            sel = by_error(tree, error, roi)
            vol = tree.assemble(sel, level=0, roi=roi, interp="nearest")
            levels = sorted({lv for lv, _ in sel})
        else:
            vol = tree.decode(level or 0, roi, workers=workers)
            levels = [level or 0]
        bytes_read, nodes = tree.bytes_read, tree.decoded_nodes
    return Decoded(vol, levels, bytes_read, nodes, time.perf_counter() - t0)


def decompress(source: Any, *, roi=None, level=None, error=None, workers=1, **_: Any) -> Volume:
    """The volume of :func:`decode` (full resolution by default)."""
    if isinstance(source, str) and source == "-":
        raise FormatError("expected a seekable octree file, found '-' (a stream)")
    return decode(source, level=level, error=error, roi=roi, workers=workers).volume


def check_header(hdr: dict, max_voxels: int = 1 << 40) -> dict:
    """Validate an octree header (kind, the octree plan, size limit); return it."""
    from .plan import Plan

    if hdr.get("kind") != KIND:
        raise FormatError(f"expected an octree header (kind {KIND!r}), found {hdr.get('kind')!r}")
    Plan.from_header(hdr, max_voxels)  # every field checked, the shape within the limit
    return hdr


def info(source: str | BinaryIO) -> dict[str, Any]:
    """Describe an octree ``.vpk`` as the container sees it (header, chunks, sizes)."""
    d = describe(source)
    check_header(d["header"])  # what info shows has been checked like what a decoder reads
    return d


def levels(source: Any) -> dict[str, Any]:
    """Nodes, chunks, bytes and errors per level of an octree (from its index only)."""
    from ..format import header as hh

    with Octree(source) as tree:
        rows = []
        stored = tree.summary.get("levels")
        stored = stored if isinstance(stored, list) else []
        for lv in range(tree.depth, -1, -1):
            t = tree.table(lv)
            n = tree.geometry.level_shape(lv)
            per = next((p for p in stored if isinstance(p, dict) and p.get("level") == lv), {})
            rows.append(
                {
                    "level": lv,
                    "shape": list(n),
                    "nodes": int(t.size),
                    "chunks": hh.integer(per.get("chunks", 0), "summary level chunks", 0, 1 << 62),
                    "nbytes": hh.integer(per.get("nbytes", 0), "summary level nbytes", 0, 1 << 62),
                    "max_deviation": float(t["maxdev"].max(initial=0.0)),
                    "E_max": float(t["E"].max(initial=0.0)),
                    "stripped": int(((t["flags"] & 1) == 0).sum()) if lv > 0 else None,
                }
            )
        return {"path": source, "depth": tree.depth, "block": tree.plan.block, "levels": rows}
