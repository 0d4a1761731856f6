"""Options and small pieces shared by the command modules (click and tqdm only)."""

from __future__ import annotations

import contextlib
import json
import sys
from collections.abc import Iterator

import click

from ..jsonsafe import jsonable

force_option = click.option("-f", "--force", is_flag=True, help="Replace an existing output file.")
json_option = click.option(
    "--json", "as_json", is_flag=True, help="Print machine-readable JSON instead of a table."
)
workers_option = click.option(
    "-j",
    "--workers",
    type=click.IntRange(min=0),
    default=1,
    show_default=True,
    help="Threads for bricks (0 = every core). The output does not depend on it.",
)


def raw_options(f):
    """--shape/--dtype/--byteorder/--offset for headerless raw input."""
    f = click.option(
        "--offset",
        type=click.IntRange(min=0),
        default=0,
        help="Raw input: bytes to skip (a header, e.g. 256 for an INRIMAGE file).",
    )(f)
    f = click.option(
        "--byteorder",
        type=click.Choice(["<", ">", "little", "big"]),
        default="<",
        help="Raw input: byte order.",
    )(f)
    f = click.option(
        "--dtype", "raw_dtype", help="Raw input: voxel type, e.g. uint8, int16, float32."
    )(f)
    f = click.option(
        "--shape",
        "raw_shape",
        help="Raw input, whatever the file's name: Z,Y,X (or T,Z,Y,X) voxels, slowest axis "
        "first and x fastest in the file, e.g. 108,256,256 (zfp's and SZ3's sizes are x first: "
        "reverse them).",
    )(f)
    return f


def read_kwargs(raw_shape: str | None, raw_dtype: str | None, byteorder: str, offset: int) -> dict:
    kw: dict = {}
    if raw_shape:
        try:
            kw["shape"] = tuple(int(v) for v in raw_shape.replace("x", ",").split(","))
        except ValueError:
            raise click.BadParameter(
                f"expected Z,Y,X integers, found {raw_shape!r}", param_hint="--shape"
            ) from None
    if raw_dtype:
        kw["dtype"] = raw_dtype
    ctx = click.get_current_context(silent=True)
    quiet = bool(ctx and (ctx.find_root().obj or {}).get("quiet"))
    if raw_shape and not quiet:  # say how the shape was understood: reversed, it reads as noise
        axes = "(t, z, y, x)" if len(kw["shape"]) == 4 else "(z, y, x)"
        click.echo(
            f"volpack: raw input of shape {axes} = {tuple(kw['shape'])}, x fastest"
            + (f", {raw_dtype}" if raw_dtype else ""),
            err=True,
        )
    if byteorder != "<" or raw_dtype:
        kw["byteorder"] = {"little": "<", "big": ">"}.get(byteorder, byteorder)
    if offset:
        kw["offset"] = offset
    return kw


@contextlib.contextmanager
def progress_bar(ctx: click.Context, desc: str, unit: str = "brick") -> Iterator:
    """Yield a ``progress(done, total)`` callback: a tqdm bar on a terminal, else lines
    every few seconds (:mod:`.notices`)."""
    obj = ctx.find_root().obj or {}
    quiet = bool(obj.get("quiet"))
    notices = obj.get("notices")
    if quiet or not sys.stderr.isatty():
        if notices is None or quiet:
            yield None
            return
        try:  # no bar: a line every few seconds instead
            yield notices.task(desc, unit)
        finally:
            notices.end_task()
        return
    from tqdm import tqdm

    bar = tqdm(desc=desc, unit=unit, file=sys.stderr, leave=False, dynamic_ncols=True)

    def update(done: int, total: int) -> None:
        if bar.total != total:
            bar.total = total
        bar.n = done
        bar.refresh()

    try:
        yield update
    finally:
        bar.close()


def emit_json(obj) -> None:
    """Print ``obj`` as strict JSON (infinite or NaN numbers become null)."""
    click.echo(json.dumps(jsonable(obj), indent=2, sort_keys=True, allow_nan=False))


def dtype_name(dtype) -> str:
    """One spelling of a voxel type everywhere: numpy's name (``uint8``, not ``|u1``)."""
    import numpy as np

    try:
        return np.dtype(dtype).name
    except TypeError:
        return str(dtype)


def fmt_bytes(n: float) -> str:
    for unit in ("B", "kB", "MB", "GB", "TB"):
        if abs(n) < 1000 or unit == "TB":
            return f"{n:.0f} {unit}" if unit == "B" else f"{n:.2f} {unit}"
        n /= 1000
    return f"{n:.2f} TB"  # pragma: no cover


def table(rows: list[list[str]], header: list[str]) -> str:
    """A plain aligned text table."""
    widths = [max(len(str(r[i])) for r in [header, *rows]) for i in range(len(header))]
    lines = [
        "  ".join(str(h).ljust(w) for h, w in zip(header, widths)),
        "  ".join("-" * w for w in widths),
    ]
    lines += [
        "  ".join(
            str(c).rjust(w) if i else str(c).ljust(w) for i, (c, w) in enumerate(zip(r, widths))
        )
        for r in rows
    ]
    return "\n".join(lines)
