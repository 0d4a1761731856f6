"""``volpack compare``: compress, decompress and report in one go."""

from __future__ import annotations

import math

import click

from .options import (
    codec_options,
    dtype_name,
    emit_json,
    fmt_bytes,
    json_option,
    parse_brick,
    phase,
    progress_bar,
    raw_options,
    workers_option,
)


@click.command(context_settings={"help_option_names": ["-h", "--help"]})
@click.argument("source")
@click.argument("other", required=False)
@codec_options
@workers_option
@raw_options
@click.option(
    "--peers",
    is_flag=True,
    help="Also run the peer codecs installed (pip install 'volpack[peers]') on the same "
    "voxels, as the benchmarks run them: losslessly zstd, Blosc2, zfp, JPEG-LS, JPEG 2000, "
    "HTJ2K and JPEG-XL slice by slice (integers up to 16 bits), fpzip and pcodec (floats); "
    "with --max-error or --rel-error zfp (accuracy mode), SZ3 and SPERR (point-wise "
    "mode) at the same absolute bound, checked on every voxel.",
)
@click.option(
    "--jpegxl-efforts",
    default="7,9",
    show_default=True,
    metavar="E,E,...",
    help="With --peers: JPEG-XL's efforts (1-10; 10 is its best and slowest).",
)
@json_option
def compare(source, other, brick, workers, read_options, peers, jpegxl_efforts, as_json, **codec):
    """Compress SOURCE in memory with the options of 'volpack compress', decompress it and
    report ratio, max error, PSNR, RMSE and encode/decode speed (zfp -s, SZ3 -a). Given a
    second volume OTHER, measure OTHER against SOURCE instead (any two files volpack
    reads, a .vpk included): max error, PSNR, RMSE and how many voxels differ.

    Nothing is written. The ratio counts the whole stream (as 'volpack info' does);
    speeds are MB/s of raw voxels, wall clock, kernel loading included. PSNR takes
    SOURCE's value range as its peak (as zfp, SZ3 and SPERR report it).

    \b
    Examples:
      volpack compare ct.nii.gz
      volpack compare sim.h5:/T --max-error 0.01 --json
      volpack compare ct.nii.gz --psnr 50 --coder huffman
      volpack compare ct.nii.gz ct.vpk             # a decoded file against its source
      volpack compare ct.nii.gz --peers            # beside zstd, JPEG-LS, JPEG-XL...
      volpack compare sim.h5:/T --rel-error 1e-4 --peers   # beside zfp, SZ3, SPERR
    """
    from .. import api
    from ..compare import compare as run

    if other is not None:
        if peers:
            raise click.UsageError("--peers codes SOURCE; it does not apply with a second volume")
        _measure(source, other, brick, read_options, as_json, codec)
        return
    efforts = _efforts(jpegxl_efforts) if peers else None
    options = {k: v for k, v in codec.items() if v is not None}
    if peers:
        _check_peer_mode(options)
    ctx = click.get_current_context()
    with phase(ctx, f"reading {source}"):
        vol = api.read_volume(source, **read_options)
    with phase(ctx, "coding, decoding and measuring"):
        r = run(vol, brick=parse_brick(brick), workers=workers, warm=peers, **options)
    if peers:
        _run_peers(vol, r, efforts)
    if as_json:
        emit_json(r)
        return
    err = "0 (lossless)" if r["lossless"] else f"{r['max_error']:.6g}"
    psnr = "inf" if r["lossless"] else f"{r['psnr']:.2f} dB"
    shape = "x".join(map(str, r["shape"]))
    click.echo(
        f"{source}: {shape} {dtype_name(r['dtype'])}, {fmt_bytes(r['raw_nbytes'])}\n"
        f"  compressed   {fmt_bytes(r['file_nbytes'])}, ratio {r['ratio']:.3f}:1, "
        f"{r['bpv']:.3f} bits/voxel\n"
        f"  max error    {err}\n"
        f"  PSNR         {psnr}, RMSE {r['rmse']:.6g}\n"
        f"  encode       {r['enc_mb_s']:.1f} MB/s ({r['enc_seconds']:.3f} s)\n"
        f"  decode       {r['dec_mb_s']:.1f} MB/s ({r['dec_seconds']:.3f} s)"
        + (f", again {r['dec_mb_s_warm']:.1f} MB/s (kernels loaded)" if peers else "")
    )
    if peers:
        _print_peers(r)


# lossy modes without one absolute bound for every voxel: no peer setting matches them
UNMATCHED = ("psnr", "ratio", "quality", "threshold")


def _efforts(text: str) -> tuple[int, ...]:
    try:
        efforts = tuple(int(v) for v in text.split(",") if v.strip())
    except ValueError:
        efforts = ()
    if not efforts or not all(1 <= e <= 10 for e in efforts):
        raise click.BadParameter(
            f"expected efforts 1-10 separated by commas, found {text!r}",
            param_hint="--jpegxl-efforts",
        )
    return efforts


def _check_peer_mode(options: dict) -> None:
    given = [k for k in UNMATCHED if k in options]
    if given:
        raise click.UsageError(
            "--peers compares losslessly or at one error bound (--max-error, --rel-error), "
            f"found --{given[0].replace('_', '-')}"
        )


def _run_peers(vol, r: dict, efforts: tuple[int, ...]) -> None:
    from ..compare import compare_peers

    bound = r["compress"].get("error_bound")  # None when no bound was asked
    with progress_bar(click.get_current_context(), "peers", unit="codec") as progress:
        rows, left_out = compare_peers(vol, bound, jpegxl_efforts=efforts, progress=progress)
    r["peers"] = rows
    r["peers_left_out"] = left_out
    r["peers_bound"] = bound


def _print_peers(r: dict) -> None:
    bound = r["peers_bound"]
    held = bound is None or r["max_error"] <= bound
    keys = ("ratio", "enc_mb_s", "max_error", "lossless")
    mine = {"name": "volpack", "bound_held": held, "dec_mb_s": r["dec_mb_s_warm"]}
    mine.update({k: r[k] for k in keys})
    rows = sorted([mine, *r["peers"]], key=lambda x: -x["ratio"])
    what = "losslessly" if bound is None else f"every voxel within {bound:.6g}"
    click.echo(
        f"  peers, {what} (each coded and decoded once, this process; volpack's decode "
        "the second, its encode with its kernels' loading):"
    )
    click.echo(
        f"    {'codec':<24} {'ratio':>9} {'x volpack':>9} {'enc MB/s':>9} {'dec MB/s':>9}  error"
    )
    for x in rows:
        if bound is None:
            err = "exact" if x["lossless"] else f"NOT EXACT (max error {x['max_error']:.6g})"
        else:
            held = "held" if x["bound_held"] else "BOUND BROKEN"
            err = f"{x['max_error']:.6g} ({held})"
        click.echo(
            f"    {x['name']:<24} {x['ratio']:>9.3f} {x['ratio'] / r['ratio']:>9.3f} "
            f"{x['enc_mb_s']:>9.1f} {x['dec_mb_s']:>9.1f}  {err}"
        )
    for line in r["peers_left_out"]:
        click.echo(f"  left out: {line}")


def _measure(source, other, brick, read_options, as_json, codec):
    from .. import api
    from ..compare import measure
    from ..errors import OptionError

    ctx = click.get_current_context()
    given = (click.core.ParameterSource.COMMANDLINE, click.core.ParameterSource.ENVIRONMENT)
    coding = [k for k in [*codec, "brick"] if ctx.get_parameter_source(k) in given]
    if coding:
        names = ", ".join(f"--{k.replace('_', '-')}" for k in sorted(coding))
        raise OptionError(
            f"coding options apply to one SOURCE (compare codes it), found {names} "
            "with a second volume"
        )
    with phase(ctx, f"reading {source}"):
        reference = api.read_volume(source, **read_options)
    with phase(ctx, f"reading {other}"):
        test = api.read_volume(other, **read_options)
    with phase(ctx, "measuring the differences"):
        r = measure(reference, test)
    if as_json:
        emit_json(r)
        return
    shape = "x".join(map(str, r["shape"]))
    dtypes = dtype_name(r["dtype"])
    if r["test_dtype"] != r["dtype"]:
        dtypes += f" against {dtype_name(r['test_dtype'])}"
    if r["identical"]:
        verdict = "identical (bit for bit)"
    else:
        verdict = f"{r['differing']} of {math.prod(r['shape'])} voxels differ"
    click.echo(
        f"{other} against {source}: {shape} {dtypes}, {verdict}\n"
        f"  max error    {r['max_error']:.6g}\n"
        f"  PSNR         {r['psnr']:.2f} dB, RMSE {r['rmse']:.6g}"
    )


COMMANDS = [compare]
