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
    raw_options,
    workers_option,
)


@click.command(context_settings={"help_option_names": ["-h", "--help"]})
@click.argument("source")
@click.argument("other", required=False)
@codec_options
@workers_option
@raw_options
@json_option
def compare(source, other, brick, workers, read_options, as_json, **codec):
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
    """
    from .. import api
    from ..compare import compare as run

    if other is not None:
        _measure(source, other, brick, read_options, as_json, codec)
        return
    vol = api.read_volume(source, **read_options)
    options = {k: v for k, v in codec.items() if v is not None}
    r = run(vol, brick=parse_brick(brick), workers=workers, **options)
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
    )


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
    r = measure(api.read_volume(source, **read_options), api.read_volume(other, **read_options))
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
