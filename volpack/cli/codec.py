"""``volpack compress`` and ``volpack decompress``."""

from __future__ import annotations

import time

import click

from . import mesh as mesh_cli
from .animation import (
    animation_compress_options,
    animation_line,
    animation_options,
    wants_animation,
)
from .mesh import mesh_line
from .octree import octree_decoded_line, octree_line
from .options import (
    accuracy,
    check_json_output,
    codec_options,
    codec_workers_option,
    emit_json,
    fmt_speed,
    force_option,
    json_option,
    parse_brick,
    phase,
    plural,
    progress_bar,
    raw_options,
    sizes,
)


@click.command(context_settings={"help_option_names": ["-h", "--help"]})
@click.argument("source")
@click.argument("target")
@codec_options
@mesh_cli.mesh_options
@animation_options
@click.option(
    "--interleave/--no-interleave",
    default=None,
    help="A 4-D (t, z, y, x) series: store its slices in (z, t) order, so each voxel is "
    "also predicted from the previous time step (MR series: 5-26 % smaller exactly, up to "
    "56 % under a bound). Default: where a sample of the series codes shorter so at the "
    "setting asked (--psnr/--ratio: the one found on the time steps, then searched again); "
    "--no-interleave codes each time step alone.",
)
@click.option(
    "--channels-last/--no-channels-last",
    default=None,
    help="A 4-D volume whose last axis holds its channels (RGB, fluorescence), (z, y, x, c): "
    "store it as the series of its channels, decoded as (z, y, x, c) again. Default: where "
    "the last axis has at most 4 voxels and every other more; --no-channels-last reads a "
    "4-D volume as (t, z, y, x).",
)
@click.option(
    "--octree",
    is_flag=True,
    help="Build a multiresolution octree (level-of-detail and region access; reads the "
    "input box by box, so it may be larger than memory). Lossless or --max-error.",
)
@click.option(
    "--block", type=int, default=16, show_default=True, help="--octree: node size k (k^3 voxels)."
)
@click.option(
    "--scheduler",
    help="--octree: run on Dask: 'local' (a LocalCluster of --workers) or a scheduler address.",
)
@codec_workers_option
@raw_options
@force_option
@json_option
@click.pass_context
def compress(
    ctx,
    source,
    target,
    codec,
    wavelet,
    coder,
    order,
    max_levels,
    brick,
    max_error,
    rel_error,
    psnr,
    ratio,
    quality,
    threshold,
    fill_value,
    effort,
    interleave,
    channels_last,
    octree,
    block,
    scheduler,
    workers,
    read_options,
    force,
    as_json,
    **extra,
) -> None:
    """Compress the volume or tetrahedral mesh SOURCE ('-': a .npy, or raw voxels with
    --shape and --dtype, on stdin) into the .vpk file TARGET ('-' for stdout).

    Lossless by default: every voxel decodes bit-exactly (floats bit for bit). Each
    brick takes the shortest of the integer lifting wavelet, 3-D prediction, a palette,
    label coding or, for floats, float prediction; --effort max also tries a predictor
    refitted along every row (1-10 % smaller, several times slower to decode) and, for
    floats, a predictor over a box of hundreds of neighbours (up to 14 % smaller, about
    2x slower to decode). One lossy
    setting turns on lossy coding: --max-error and
    --rel-error promise a bound on every voxel (integers and floats; NaN, Inf and
    --fill-value voxels come back exactly); --psnr and --ratio search the setting that
    reaches the target; --quality and --threshold are the method's own knobs.

    \b
    Examples:
      volpack compress ct.nii.gz ct.vpk
      volpack compress ct.nii.gz ct.vpk --effort max
      volpack compress ct.nii.gz ct.vpk --codec wavelet --wavelet 26 --coder huffman --brick 64
      volpack compress big.h5:/density big.vpk --workers 2
      volpack compress sim.h5:/T T.vpk --max-error 0.01
      volpack compress ct.nii.gz ct.vpk --psnr 50
      volpack compress ct.nii.gz ct.vpk --quality 63
      volpack compress run.nii.gz run.vpk --gop IBBPBBPBB --quality 63
      volpack compress 'frames/*.npy' run.vpk --gop IPPP --max-error 0.5
      volpack compress storm.npy storm.vpk --gop IPPP --fill-value -9999   (lossless floats)
      volpack compress mesh.vtu mesh.vpk --bits 16        (tetrahedral mesh: --bits,
      volpack compress hex.msh mesh.vpk --tetrahedralize   --lossless-geometry, ...)
      volpack compress big.h5:/density big.vpk --octree --max-error 2 --workers 2
      cat ct.npy | volpack compress - ct.vpk                       (standard input)
      cat ct.raw | volpack compress - ct.vpk --shape 512,512,512 --dtype uint16
      volpack compress ct.npy - | ssh host 'volpack decompress - ct.npy'
    """
    from .. import api

    check_json_output(as_json, target)
    _check_vpk_target(target)
    # No --coder: each codec's own default (auto for the error-bounded codec, arith for
    # the others); animations and octrees take arith.
    shared = {
        "codec": codec, "wavelet": wavelet, "coder": coder, "order": order,
        "max_error": max_error, "rel_error": rel_error, "psnr": psnr, "ratio": ratio,
        "quality": quality, "threshold": threshold, "fill_value": fill_value,
    }  # fmt: skip
    lossy = {k: v for k, v in shared.items() if k not in ("codec", "wavelet", "coder", "order")}
    not_a_volume = (
        mesh_cli.is_mesh_source(source) or wants_animation(source, extra["gop"])
        or octree or scheduler
    )  # fmt: skip
    if effort is not None and not_a_volume:
        raise click.UsageError(
            f"--effort applies to a volume under an error bound, found --effort {effort} "
            "with a mesh, an animation or --octree"
        )
    for flag, value in (("--channels-last", channels_last), ("--interleave", interleave)):
        if value is not None and not_a_volume:
            raise click.UsageError(
                f"{flag} applies to a 4-D volume, found it with a mesh, an animation or --octree"
            )
    if mesh_cli.is_mesh_source(source):
        kind, unit = "mesh", None
        opts = mesh_cli.compress_options(extra)
    elif wants_animation(source, extra["gop"]):
        from ..animation.stream import LOSSY_REFUSED

        _refuse(
            "animations take --max-error or --quality (or neither: lossless); found",
            lossy,
            LOSSY_REFUSED,
        )
        if codec not in ("auto", "wavelet", "lossless"):
            raise click.UsageError(
                f"animations take --codec auto, wavelet or lossless; found --codec {codec}"
            )
        kind, unit = "animation", "frame"
        opts = {**shared, **animation_compress_options(extra), "max_levels": max_levels}
        opts["coder"] = coder or "arith"
        opts.update(brick=parse_brick(brick), read_options=read_options)
    elif octree or scheduler:
        from ..octree.stream import REFUSED

        _refuse("--octree takes --max-error or nothing (lossless), found", lossy, REFUSED)
        if target == "-":
            raise click.UsageError("--octree writes a seekable file, not '-'")
        kind, unit = "octree", "super-brick"
        opts = {k: v for k, v in lossy.items() if v is not None}
        opts.update(wavelet=wavelet or "53", coder=coder or "arith", order=order or "dfs",
                    block=block)  # fmt: skip
        opts.update(scheduler=scheduler, workers=workers, read_options=read_options)
    else:
        kind, unit = "volume", "brick"
        opts = {**shared, "max_levels": max_levels, "brick": parse_brick(brick)}
        opts.update(workers=workers, read_options=read_options)
        if effort is not None:
            opts["effort"] = effort
        if interleave is not None:
            opts["interleave"] = interleave
        if channels_last is not None:
            opts["channels_last"] = channels_last
    with mesh_cli.echo_warnings(), progress_bar(ctx, "compress", unit=unit) as progress:
        if unit is not None:
            opts["progress"] = progress
        stats = api.compress(source, target, kind=kind, force=force, **opts)
    if as_json:
        emit_json(stats)
    elif target != "-":
        click.echo(SUMMARIES[kind](target, stats), err=True)


@click.command(context_settings={"help_option_names": ["-h", "--help"]})
@click.argument("source")
@click.argument("target")
@click.option("--roi", help="Decode only Z0:Z1,Y0:Y1,X0:X1 (reads only the bricks it touches).")
@click.option("--frame", type=click.IntRange(min=0), help="Decode one time step of a 4-D volume.")
@click.option(
    "--batch",
    "batch_mode",
    is_flag=True,
    help="SOURCE and TARGET are folders: decode every .vpk below SOURCE, mirroring the tree "
    "(--workers files at once).",
)
@click.option(
    "--format",
    "out_format",
    type=click.Choice(["npy", "nii", "nii.gz", "nrrd", "h5", "tif", "raw", "mha", "vti", "mrc"]),
    default="npy",
    show_default=True,
    help="With --batch: the format of the decoded files.",
)
@click.option(
    "--level",
    type=click.IntRange(min=0),
    help="Octree files: decode at 1/2^LEVEL resolution per axis (reads only those nodes).",
)
@click.option(
    "--error",
    type=float,
    help="Octree files: the coarsest nodes whose voxels deviate at most this much.",
)
@codec_workers_option
@force_option
@json_option
@click.pass_context
def decompress(
    ctx,
    source,
    target,
    roi,
    frame,
    batch_mode,
    out_format,
    level,
    error,
    workers,
    force,
    as_json,
) -> None:
    """Decode the .vpk file SOURCE ('-' for stdin) into TARGET (any writable format).

    \b
    Examples:
      volpack decompress ct.vpk ct.npy
      volpack decompress ct.vpk roi.npy --roi 40:80,100:200,100:200
      volpack decompress ct.vpk - | python -c "import numpy, sys; print(numpy.load(sys.stdin.buffer).shape)"
      volpack decompress ct.vpk - | volpack convert - ct.nii.gz    (a .npy through the pipe)
      volpack decompress out/ restored/ --batch --format nii.gz --workers 4
      volpack decompress big.vpk coarse.npy --level 3
      volpack decompress big.vpk approx.npy --error 10
    """
    check_json_output(as_json, target)
    if batch_mode:
        if roi or frame is not None:
            raise click.UsageError("--roi and --frame do not apply with --batch")
        from .. import batch
        from .batch import run_batch

        tasks = batch.plan([source], target, suffix="." + out_format, kind="decompress")
        run_batch(ctx, tasks, target, "decompress", workers, force, as_json)
        return
    from .. import api
    from .. import io as vio
    from ..metrics import throughput

    kind = api.kind_of(source)
    if kind == "mesh":
        return mesh_cli.decompress(source, target, force=force, as_json=as_json)
    if level is not None or error is not None or kind == "octree":
        from ..octree.stream import decode

        vio.check_outputs(target, force=force, inputs=(source,))
        with phase(ctx, f"decoding {source}"):
            d = decode(source, level=level, error=error, roi=roi, workers=workers)
        with phase(ctx, f"writing {target}"):
            api.write_volume(d.volume, target, force=force)
        stats = {"target": target, "shape": list(d.volume.shape), "dtype": str(d.volume.dtype)}
        stats.update(levels=d.levels, bytes_read=d.bytes_read, nodes_decoded=d.nodes_decoded)
        stats["seconds"] = d.seconds
        if as_json:
            emit_json(stats)
        elif target != "-":
            click.echo(octree_decoded_line(target, stats), err=True)
        return
    vio.check_outputs(target, force=force, inputs=(source,))
    t0 = time.perf_counter()
    with progress_bar(ctx, "decompress") as progress:
        vol = api.read_volume_from(source, roi=roi, frame=frame, workers=workers, progress=progress)
    seconds = time.perf_counter() - t0
    with phase(ctx, f"writing {target}"):
        api.write_volume(vol, target, force=force)
    stats = {
        "target": target,
        "shape": list(vol.shape),
        "dtype": str(vol.dtype),
        "seconds": seconds,
        "mb_per_s": throughput(vol.nbytes, seconds),
    }
    if as_json:
        emit_json(stats)
    elif target != "-":
        click.echo(
            f"{target}: {'x'.join(map(str, vol.shape))} {vol.dtype}, "
            f"{fmt_speed(stats['mb_per_s'], seconds)}",
            err=True,
        )


def _check_vpk_target(target: str) -> None:
    """compress writes a .vpk: under the name of another format (ct.nii.gz, ct.npy) it
    would mislead every other program that opens it."""
    from ..api import check_vpk_name

    check_vpk_name(target, "a TARGET", "compress writes volpack's own format")


def _refuse(message: str, given: dict, refused: tuple[str, ...]) -> None:
    """A usage error naming the flags of ``refused`` options that were given."""
    flags = ["--" + k.replace("_", "-") for k in refused if given.get(k) is not None]
    if flags:
        raise click.UsageError(f"{message} {', '.join(flags)}")


def _volume_line(target: str, stats: dict) -> str:
    w = stats["workers"]
    return (
        f"{target}: {sizes(stats['file_nbytes'], stats['raw_nbytes'], stats['file_ratio'])}, "
        f"{accuracy(stats)}, "
        f"{fmt_speed(stats['mb_per_s'], stats['seconds'])} "
        f"({stats['bricks']} {plural('brick', stats['bricks'])}, {w} {plural('worker', w)}"
        + (", the last axis as channels" if stats.get("channels") else "")
        + (
            f", a palette of {stats['tuples']} voxel tuples and their index volume"
            if stats.get("tuples")
            else ""
        )
        + (
            f", {'channels' if stats.get('channels') else 'time steps'} interleaved)"
            if stats.get("layout")
            else ")"
        )
    )


SUMMARIES = {
    "volume": _volume_line,
    "animation": animation_line,
    "octree": octree_line,
    "mesh": mesh_line,
}
"""The one line ``volpack compress`` prints on standard error, per stream kind."""


COMMANDS = [compress, decompress]
