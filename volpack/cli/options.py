"""Options and small pieces shared by the command modules (click and tqdm only)."""

from __future__ import annotations

import contextlib
import functools
import json
import sys
from collections.abc import Iterator

import click

from ..jsonsafe import jsonable


def option(flags: str, help: str, kind=None, default=None, **extra):
    """One row of an option table: a click option from FLAGS (``"-j --workers"``; a last
    word without dashes names the parameter; ``"--x/--no-x"`` is a switch), HELP, KIND
    (``bool``: a flag; a list: the choices; a pair: a whole-number range, None unbounded;
    else a click type) and DEFAULT (shown in ``--help``)."""
    if kind is bool:
        extra["is_flag"] = True
    elif isinstance(kind, list):
        extra["type"] = click.Choice(kind)
    elif isinstance(kind, tuple):
        extra["type"] = click.IntRange(*kind)
    elif kind is not None:
        extra["type"] = kind
    if default is not None:
        extra["default"] = default
        extra.setdefault("show_default", True)
    return click.option(*flags.split(), help=help, **extra)


def options(*rows):
    """Decorate a command with option rows (:func:`option`), listed in this order."""
    return lambda f: functools.reduce(lambda g, o: o(g), reversed(rows), f)


# True in a process that ends with its command (the console entry, volpack.cli.run)
WHOLE_PROCESS = False


@contextlib.contextmanager
def imports_without_gc() -> Iterator[None]:
    """Import a command's libraries with Python's cycle collector paused. Imports make
    modules, classes and functions, never garbage, but the collector scanned them over
    and over while numba and the rest were imported, and again at each full collection
    later: 60-100 ms of CPU of a render of a cached volume. In a process that ends with
    its command (:data:`WHOLE_PROCESS`) they are frozen too (``gc.freeze``: no
    collection looks at them again); elsewhere (tests, a caller's own process) freezing
    would keep the caller's unreachable objects for good, so it is skipped."""
    import gc

    enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if WHOLE_PROCESS:
            gc.freeze()
        if enabled:
            gc.enable()


force_option = option("-f --force", "Replace an existing output file.", bool)


def _note_json(ctx: click.Context, param: click.Parameter, value: bool) -> bool:
    """Remember --json: an error is then reported on standard output as JSON too
    (:meth:`volpack.cli.VolpackGroup.invoke`), so a script's parser never gets nothing."""
    if value:
        ctx.meta["volpack.json"] = True
    return value


json_option = option(
    "--json as_json",
    'Print machine-readable JSON instead of a table (an error as {"error": MESSAGE}).',
    bool,
    callback=_note_json,
)
workers_option = option(
    "-j --workers", "Threads for bricks (0 = every core). The output does not depend on it.",
    (0, None), 1,
)  # fmt: skip
# compress and decompress: a user's own coding takes the machine (compare times one core
# against single-threaded peers, so it keeps workers_option's 1)
codec_workers_option = option(
    "-j --workers",
    "Threads for bricks: 0 = every core, but at most one a brick and as many as half the "
    "memory holds; 1 for one core. The output does not depend on it.",
    (0, None), 0,
)  # fmt: skip
RAW_OPTIONS = options(
    option("--shape raw_shape",
           "Raw input, whatever the file's name: Z,Y,X (or T,Z,Y,X) voxels, slowest axis "
           "first and x fastest in the file, e.g. 108,256,256 (zfp's and SZ3's sizes are x "
           "first: reverse them)."),
    option("--dtype raw_dtype", "Raw input: voxel type, e.g. uint8, int16, float32."),
    option("--byteorder", "Raw input: byte order.", ["<", ">", "little", "big"], "<",
           show_default=False),
    option("--offset", "Raw input: bytes to skip (a header, e.g. 256 for an INRIMAGE file).",
           (0, None), 0, show_default=False),
)  # fmt: skip


def raw_options(f):
    """--shape/--dtype/--byteorder/--offset for headerless raw input, handed to the command
    as one ``read_options`` dict (:func:`read_kwargs`)."""

    @functools.wraps(f)
    def command(*args, raw_shape, raw_dtype, byteorder, offset, **kw):
        return f(*args, read_options=read_kwargs(raw_shape, raw_dtype, byteorder, offset), **kw)

    return RAW_OPTIONS(command)


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
def progress_bar(ctx: click.Context, desc: str, unit: str | None = "brick") -> Iterator:
    """Yield a ``progress(done, total)`` callback: a tqdm bar on a terminal, else lines
    every few seconds (:mod:`.notices`); None with ``unit=None`` (nothing to count)."""
    obj = ctx.find_root().obj or {}
    quiet = bool(obj.get("quiet"))
    notices = obj.get("notices")
    if quiet or unit is None or not sys.stderr.isatty():
        if notices is None or quiet or unit is None:
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


def phase(ctx: click.Context, what: str):
    """A context naming a step with nothing to count ('writing ct.nii.gz') while it
    lasts, so that no long step is silent (:meth:`.notices.Notices.phase`)."""
    import contextlib

    notices = (ctx.find_root().obj or {}).get("notices")
    return contextlib.nullcontext() if notices is None else notices.phase(what)


def emit_json(obj) -> None:
    """Print ``obj`` as strict JSON (infinite or NaN numbers become null)."""
    click.echo(json.dumps(jsonable(obj), indent=2, sort_keys=True, allow_nan=False))


def check_json_output(as_json: bool, *outputs: str) -> None:
    """--json prints on standard output, so not where an output of '-' writes its data:
    the JSON would trail the stream and break its reader."""
    if as_json and "-" in outputs:
        raise click.UsageError(
            "expected --json or an output of '-', found both (both write to standard output)"
        )


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


def fmt_speed(mb_per_s: float, seconds: float) -> str:
    """'16.5 MB/s in 0.291 s': three significant digits down to 0.001 MB/s, so a small
    volume's speed is not printed as 0.0, and the wall time it was measured over beside it."""
    speed = f"{mb_per_s:.3g}" if mb_per_s >= 1 else f"{mb_per_s:.3f}" if mb_per_s >= 1e-3 else "<0.001"
    return f"{speed} MB/s in {seconds:.3g} s"


def sizes(nbytes: int, raw_nbytes: int, ratio: float) -> str:
    """'1.20 MB from 7.08 MB, ratio 5.900:1': what a summary line says of the sizes."""
    return f"{fmt_bytes(nbytes)} from {fmt_bytes(raw_nbytes)}, ratio {ratio:.3f}:1"


def accuracy(stats: dict, bound: float | None = None) -> str:
    """'lossless', or 'max error E, PSNR P dB' (``bound``: the bound asked, beside E)."""
    if stats.get("lossless", True):
        return "lossless"
    asked = "" if bound is None else f" (bound {bound:g})"
    return f"max error {stats['max_error']:g}{asked}, PSNR {db(stats.get('psnr'), stats['max_error'])}"


def db(psnr: float | None, max_error: float | None) -> str:
    """A PSNR for people: 'P dB', 'inf' when nothing differs, and 'unknown' when the
    summary has none although voxels differ (errors whose squares leave float64's range,
    e.g. float64 data near 1e300 or 1e-300)."""
    if psnr is not None:
        return f"{psnr:.2f} dB"
    return "inf" if not max_error else "unknown (squared errors beyond float64's range)"


def plural(word: str, n: int) -> str:
    """``word`` for one, ``word + "s"`` for any other count."""
    return word if n == 1 else word + "s"


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


def parse_brick(value: str | None) -> int | tuple[int, int, int] | None:
    if value is None:  # the codec's default (volume_codec.bricks.default_brick)
        return None
    parts = value.replace("x", ",").split(",")
    try:
        nums = [int(p) for p in parts]
    except ValueError:
        raise click.BadParameter(
            f"expected N or Z,Y,X, found {value!r}", param_hint="--brick"
        ) from None
    if len(nums) not in (1, 3):
        raise click.BadParameter(f"expected N or Z,Y,X, found {value!r}", param_hint="--brick")
    return nums[0] if len(nums) == 1 else tuple(nums)  # type: ignore[return-value]


codec_options = options(
    option("--codec",
           "auto: lossless (per brick, the wavelet, 3-D prediction with a palette, labels or "
           "float prediction) for integers and floats (64-bit integers: byte-shuffled zstd, "
           "palettes and labels). fast: lossless too, decoding several times faster (MED-style "
           "prediction and table-driven rANS) at a few per cent less ratio.",
           ["auto", "lossless", "fast", "wavelet", "zstd"], "auto"),
    option("--wavelet",
           "Reversible lifting filter: 5/3 (CDF 2,2), 2/6 (TS), Haar (S-transform), 9/7-M; "
           "or, lossy only, the float Daubechies-4, Coiflet-6 and CDF 9/7 (for comparison). "
           "Lossless (--codec auto), it and --coder apply only to the bricks the wavelet codes "
           "shortest; --codec wavelet codes every brick with them. Default: 53.",
           ["53", "26", "haar", "97m", "d4", "c6", "cdf97"]),
    option("--coder",
           "arith: best ratio; arith2: arith's model, 1.6-2x as fast to decode, up to 1 % "
           "larger; huffman: fixed code, fastest decode; rle: run-length Huffman for sparse "
           "data; static: arith's model with fixed tables; auto: arith2 unless arith is "
           "shorter, per coefficient stream. Default: auto under an error bound (--max-error, "
           "--rel-error, floats with --psnr/--ratio), else arith.",
           ["arith", "arith2", "huffman", "rle", "static", "auto"]),
    option("--order",
           "Coefficient scan: octree depth-first with zero-subtree stripping, or line by line. "
           "Default: dfs.",
           ["dfs", "line"]),
    option("--levels max_levels", "Cap the decomposition levels per axis.", (0, 16)),
    option("--brick", "Brick size N or Z,Y,X; bricks decode independently. Default 64; a "
           "float volume under an error bound is one brick up to 4M voxels, else 128; "
           "exact floats and integer volumes up to 2M voxels coded exactly: 128."),
    option("--max-error", "Lossy: every voxel decodes within this absolute error (checked "
           "on every voxel); 0 is exact: coded losslessly (with --effort fast, by --codec "
           "fast).", float),
    option("--rel-error", "Lossy: --max-error as a fraction of the value range (0: "
           "lossless).", float),
    option(
        "--psnr",
        "Lossy: reach this PSNR in dB (within 0.5 dB; where no setting does, the nearest "
        "above it, with a warning).",
        float,
    ),
    option(
        "--ratio",
        "Lossy: reach this compression ratio of the file, container included (within 5%; "
        "where no setting does, the nearest above it, with a warning).",
        float,
    ),
    option("--quality", "Lossy, the method's scale: 255 (best), 127, 63, 31, 15 (integer "
           "volumes).", (1, 65535)),
    option("--threshold", "Lossy: drop wavelet coefficients below this size, in value units "
           "(integer volumes).", float),
    option("--effort", "Lossy with a bound (--max-error, --rel-error; --psnr, --ratio on "
           "floats): 'default' makes every coding of each brick and keeps the shortest; "
           "'fast' makes one or two (the quantised voxels by the fast lossless codec; "
           "floats: also interpolation), faster to encode and 2-4x faster to decode, at "
           "some ratio; 'max' keeps the shortest coding whatever its "
           "decoding speed. The bound holds either way. Lossless: 'max' also refits a "
           "predictor along every row of integer bricks: 1-10 % smaller on scans, 4-10x "
           "slower to decode. [default: default]",
           ["default", "fast", "max"]),
    option("--fill-value", "A value meaning 'no data' (e.g. -2.56e33); restored exactly, "
           "like NaN and Inf.", float),
)  # fmt: skip
"""The codec and lossy options of ``volpack compress``, which ``volpack batch`` shares."""
