"""``volpack compress`` and ``volpack decompress``."""

from __future__ import annotations

import time

import click

from . import mesh as mesh_cli
from .animation import ANIMATION_KEYS, animation_options, wants_animation
from .options import (
    emit_json,
    fmt_bytes,
    force_option,
    json_option,
    progress_bar,
    raw_options,
    read_kwargs,
    workers_option,
)


def _brick(value: str) -> int | tuple[int, int, int]:
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


@click.command(context_settings={"help_option_names": ["-h", "--help"]})
@click.argument("source")
@click.argument("target")
@click.option(
    "--codec",
    type=click.Choice(["auto", "lossless", "wavelet", "zstd"]),
    default="auto",
    show_default=True,
    help="auto: lossless (per brick, the wavelet or 3-D prediction with a palette) for "
    "8/16/32-bit integers and 16/32-bit floats, byte-shuffled zstd (exact) for the rest.",
)
@click.option(
    "--wavelet",
    type=click.Choice(["53", "26", "haar", "97m", "d4", "c6", "cdf97"]),
    default="53",
    show_default=True,
    help="Reversible lifting filter: 5/3 (CDF 2,2), 2/6 (TS), Haar (S-transform), 9/7-M; "
    "or, lossy only, the float Daubechies-4, Coiflet-6 and CDF 9/7 (for comparison).",
)
@click.option(
    "--coder",
    type=click.Choice(["arith", "huffman", "rle"]),
    default="arith",
    show_default=True,
    help="arith: best ratio; huffman: fixed code, fastest decode; rle: run-length Huffman for sparse data.",
)
@click.option(
    "--order",
    type=click.Choice(["dfs", "line"]),
    default="dfs",
    show_default=True,
    help="Coefficient scan: octree depth-first with zero-subtree stripping, or line by line.",
)
@click.option(
    "--levels",
    "max_levels",
    type=click.IntRange(0, 16),
    help="Cap the decomposition levels per axis.",
)
@click.option(
    "--brick",
    default="64",
    show_default=True,
    help="Brick size N or Z,Y,X; bricks decode independently.",
)
@click.option(
    "--max-error",
    type=float,
    help="Lossy: every voxel decodes within this absolute error (checked on every voxel).",
)
@click.option(
    "--rel-error", type=float, help="Lossy: --max-error as a fraction of the value range."
)
@click.option("--psnr", type=float, help="Lossy: reach this PSNR in dB (within 0.5 dB).")
@click.option("--ratio", type=float, help="Lossy: reach this compression ratio (within 5%).")
@click.option(
    "--quality",
    type=click.IntRange(1, 65535),
    help="Lossy, the method's scale: 255 (best), 127, 63, 31, 15 (integer volumes).",
)
@click.option(
    "--threshold",
    type=float,
    help="Lossy: drop wavelet coefficients below this size, in value units (integer volumes).",
)
@click.option(
    "--fill-value",
    type=float,
    help="A value meaning 'no data' (e.g. -2.56e33); restored exactly, like NaN and Inf.",
)
@mesh_cli.mesh_options
@animation_options
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
@workers_option
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
    octree,
    block,
    scheduler,
    workers,
    raw_shape,
    raw_dtype,
    byteorder,
    offset,
    force,
    as_json,
    **extra,
) -> None:
    """Compress the volume or tetrahedral mesh SOURCE into the .vpk file TARGET ('-' for stdout).

    Lossless by default: every voxel decodes bit-exactly. Integer volumes (8, 16 and
    32 bit) use the integer lifting wavelet codec; floats are stored exactly by
    byte-shuffled zstd. One lossy setting turns on lossy coding: --max-error and
    --rel-error promise a bound on every voxel (integers and floats; NaN, Inf and
    --fill-value voxels come back exactly); --psnr and --ratio search the setting that
    reaches the target; --quality and --threshold are the method's own knobs.

    \b
    Examples:
      volpack compress ct.nii.gz ct.vpk
      volpack compress ct.nii.gz ct.vpk --wavelet 26 --coder huffman --brick 64
      volpack compress big.h5:/density big.vpk --workers 2
      volpack compress sim.h5:/T T.vpk --max-error 0.01
      volpack compress ct.nii.gz ct.vpk --psnr 50
      volpack compress ct.nii.gz ct.vpk --quality 63
      volpack compress run.nii.gz run.vpk --gop IBBPBBPBB --quality 63
      volpack compress 'frames/*.npy' run.vpk --gop IPPP --max-error 0.5
      volpack compress mesh.vtu mesh.vpk --bits 16        (tetrahedral mesh: --bits,
      volpack compress hex.msh mesh.vpk --tetrahedralize   --lossless-geometry, ...)
      volpack compress big.h5:/density big.vpk --octree --max-error 2 --workers 2
    """
    if mesh_cli.is_mesh_source(source):
        mesh_opts = {k: v for k, v in extra.items() if k not in ANIMATION_KEYS}
        return mesh_cli.compress(source, target, force=force, as_json=as_json, **mesh_opts)
    if wants_animation(source, extra["gop"]):
        from .animation import run_compress

        opts = {k: extra[k] for k in ANIMATION_KEYS}
        kw = dict(locals())
        kw["read_options"] = read_kwargs(raw_shape, raw_dtype, byteorder, offset)
        return run_compress(ctx, source, target, as_json, force, opts, **_shared(kw))
    if octree or scheduler:
        from . import octree as octree_cli

        octree_cli.compress(ctx, read_kwargs(raw_shape, raw_dtype, byteorder, offset))
        return
    from .. import api
    from .. import io as vio
    from ..atomic import check_output

    check_output(target, force=force, inputs=(vio.parse_spec(source)[0],))
    vol = vio.read_volume(source, **read_kwargs(raw_shape, raw_dtype, byteorder, offset))
    with progress_bar(ctx, "compress") as progress:
        stats = api.compress(
            vol,
            target,
            codec=codec,
            wavelet=wavelet,
            coder=coder,
            order=order,
            max_levels=max_levels,
            brick=_brick(brick),
            max_error=max_error,
            rel_error=rel_error,
            psnr=psnr,
            ratio=ratio,
            quality=quality,
            threshold=threshold,
            fill_value=fill_value,
            workers=workers,
            force=force,
            progress=progress,
        )
    if as_json:
        emit_json(stats)
    elif target != "-":
        click.echo(
            f"{target}: {fmt_bytes(stats['nbytes'])} from {fmt_bytes(stats['raw_nbytes'])}, "
            f"ratio {stats['ratio']:.3f}:1, {_accuracy(stats)}, {stats['mb_per_s']:.1f} MB/s "
            f"({stats['bricks']} bricks, {stats['workers']} worker{'s' if stats['workers'] != 1 else ''})",
            err=True,
        )


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
    type=click.Choice(["npy", "nii", "nii.gz", "nrrd", "h5", "tif", "raw"]),
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
@workers_option
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
      volpack decompress out/ restored/ --batch --format nii.gz --workers 4
      volpack decompress big.vpk coarse.npy --level 3
      volpack decompress big.vpk approx.npy --error 10
    """
    if not batch_mode and mesh_cli.is_mesh_stream(source):
        return mesh_cli.decompress(source, target, force=force, as_json=as_json)
    if batch_mode:
        if roi or frame is not None:
            raise click.UsageError("--roi and --frame do not apply with --batch")
        from .. import batch
        from .batch import run_batch

        tasks = batch.plan([source], target, suffix="." + out_format, kind="decompress")
        run_batch(
            ctx,
            tasks,
            target,
            workers=workers,
            scheduler=None,
            resume=False,
            force=force,
            fail_fast=False,
            report_path=None,
            as_json=as_json,
            desc="decompress",
        )
        return
    from . import octree as octree_cli

    if level is not None or error is not None or octree_cli.is_octree(source):
        octree_cli.decompress(
            ctx,
            source,
            target,
            roi=roi,
            level=level,
            error=error,
            force=force,
            as_json=as_json,
            workers=workers,
        )
        return
    from .. import api
    from .. import io as vio
    from ..atomic import check_output

    check_output(vio.parse_spec(target)[0], force=force, inputs=(source,))
    t0 = time.perf_counter()
    with progress_bar(ctx, "decompress") as progress:
        vol = api.decompress(source, roi=roi, frame=frame, workers=workers, progress=progress)
    seconds = time.perf_counter() - t0
    vio.write_volume(vol, target, force=force)
    stats = {
        "target": target,
        "shape": list(vol.shape),
        "dtype": str(vol.dtype),
        "seconds": seconds,
        "mb_per_s": vol.nbytes / 1e6 / max(seconds, 1e-9),
    }
    if as_json:
        emit_json(stats)
    elif target != "-":
        click.echo(
            f"{target}: {'x'.join(map(str, vol.shape))} {vol.dtype}, {stats['mb_per_s']:.1f} MB/s",
            err=True,
        )


def _shared(kw: dict) -> dict:
    keys = ("codec", "wavelet", "coder", "order", "max_levels", "max_error", "rel_error")
    keys += ("psnr", "ratio", "quality", "threshold", "fill_value", "read_options")
    out = {k: kw[k] for k in keys}
    out["brick"] = _brick(kw["brick"])
    return out


def _accuracy(stats: dict) -> str:
    if stats.get("lossless", True):
        return "lossless"
    psnr = stats.get("psnr")
    return f"max error {stats['max_error']:g}, PSNR {'inf' if psnr is None else f'{psnr:.2f}'} dB"


COMMANDS = [compress, decompress]
