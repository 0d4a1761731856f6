"""``volpack convert``: change format and preprocess in one pass."""

from __future__ import annotations

import click

from .options import emit_json, force_option, json_option, raw_options, read_kwargs


@click.command(context_settings={"help_option_names": ["-h", "--help"]})
@click.argument("source")
@click.argument("target")
@raw_options
@click.option("--crop", help="Keep Z0:Z1,Y0:Y1,X0:X1 (numpy-style ranges; empty means all).")
@click.option(
    "--pad",
    "pad_to",
    type=click.IntRange(min=1),
    help="Pad each axis up to a multiple of N (edge values).",
)
@click.option(
    "--downsample", type=click.IntRange(min=1), help="Shrink each spatial axis by this factor."
)
@click.option(
    "--method",
    type=click.Choice(["box", "gaussian"]),
    default="box",
    show_default=True,
    help="Filter for --downsample.",
)
@click.option(
    "--isotropic", is_flag=True, help="Resample to isotropic spacing (the finest axis), trilinear."
)
@click.option(
    "--spacing", "new_spacing", type=float, help="Resample to this isotropic spacing, trilinear."
)
@click.option("--window", help="Clamp values to LO:HI.")
@click.option(
    "--mask-fill", type=float, help="Treat this value as 'no data': it joins NaN/Inf in the mask."
)
@click.option(
    "--quantize",
    "bits",
    type=click.IntRange(1, 32),
    help="Floats to N-bit unsigned integers; scale, offset and max error are recorded.",
)
@click.option(
    "--astype",
    help="Convert the dtype (explicit rounding, out-of-range values clipped and counted).",
)
@click.option(
    "--rounding",
    type=click.Choice(["nearest", "floor", "trunc"]),
    default="nearest",
    show_default=True,
)
@force_option
@json_option
def convert(
    source,
    target,
    raw_shape,
    raw_dtype,
    byteorder,
    offset,
    crop,
    pad_to,
    downsample,
    method,
    isotropic,
    new_spacing,
    window,
    mask_fill,
    bits,
    astype,
    rounding,
    force,
    as_json,
) -> None:
    """Read SOURCE, apply the steps asked for (in the order listed), write TARGET.

    The output format follows TARGET's extension ('-' writes .npy to standard output;
    a .vpk target is compressed losslessly). The input is never modified and the output
    is written atomically; an existing TARGET needs --force.

    \b
    Examples:
      volpack convert ct.nrrd ct.npy --crop 10:90,0:256,0:256 --downsample 2
      volpack convert map.nii.gz map_u16.npy --quantize 16
      cat vol.npy | volpack convert - out.h5:/data
      volpack convert scan.raw scan.nii.gz --shape 108,256,256 --dtype int16
    """
    from .. import api, prep
    from .. import io as vio
    from ..format.atomic import check_output

    check_output(vio.parse_spec(target)[0], force=force, inputs=(source,))
    vol = api.read_volume(source, **read_kwargs(raw_shape, raw_dtype, byteorder, offset))
    steps = []
    if crop:
        vol = prep.crop(vol, crop)
        steps.append(f"crop {crop}")
    if pad_to:
        vol = prep.pad_to_multiple(vol, pad_to)
        steps.append(f"pad to x{pad_to}")
    if downsample and downsample > 1:
        vol = prep.downsample(vol, downsample, method=method)
        steps.append(f"downsample {downsample} ({method})")
    if isotropic or new_spacing:
        sp = new_spacing or min(vol.spacing)
        vol = prep.resample(vol, sp)
        steps.append(f"resample to {sp:g}")
    if window:
        try:
            lo, hi = (float(v) for v in window.split(":"))
        except ValueError:
            raise click.BadParameter(
                f"expected LO:HI, found {window!r}", param_hint="--window"
            ) from None
        vol = prep.window(vol, lo, hi)
        steps.append(f"window {lo:g}:{hi:g}")
    if vol.dtype.kind == "f" or mask_fill is not None:
        if mask_fill is not None or _has_special(vol):
            vol = prep.mask_special(vol, fill_value=mask_fill)
            steps.append("mask NaN/Inf/fill")
    if bits:
        vol = prep.quantize(vol, bits)
        steps.append(f"quantize {bits} bits")
    if astype:
        vol = prep.astype(vol, astype, rounding=rounding)
        steps.append(f"astype {astype}")
    if target.endswith(".vpk"):
        stats = api.compress(vol, target, force=force)
    else:
        vio.write_volume(vol, target, force=force)
        stats = None
    if as_json:
        d = vol.describe()
        d.update(steps=steps, target=target, compress=stats)
        emit_json(d)
    elif target != "-":
        shape = "x".join(map(str, vol.shape))
        click.echo(
            f"{target}: {shape} {vol.dtype}" + (f" after {', '.join(steps)}" if steps else ""),
            err=True,
        )
        q = vol.meta.get("quantize")
        if q:
            click.echo(
                f"  quantized: scale {q['scale']:.6g}, offset {q['offset']:.6g}, max error {q['max_error']:.6g}",
                err=True,
            )


def _has_special(vol) -> bool:
    import numpy as np

    return vol.dtype.kind == "f" and not bool(np.isfinite(vol.data).all())


COMMANDS = [convert]
