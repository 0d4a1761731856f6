"""``volpack convert``: change format and preprocess in one pass."""

from __future__ import annotations

import click

from .options import (
    check_json_output,
    emit_json,
    force_option,
    json_option,
    option,
    options,
    phase,
    progress_bar,
    raw_options,
)


@click.command(context_settings={"help_option_names": ["-h", "--help"]})
@click.argument("source")
@click.argument("target")
@raw_options
@options(
    option("--crop", "Keep Z0:Z1,Y0:Y1,X0:X1 (numpy-style ranges; empty means all)."),
    option("--pad pad_to", "Pad each axis up to a multiple of N (edge values).", (1, None)),
    option("--downsample", "Shrink each spatial axis by this factor.", (1, None)),
    option("--method", "Filter for --downsample.", ["box", "gaussian"], "box"),
    option("--isotropic", "Resample to isotropic spacing (the finest axis), trilinear.", bool),
    option("--resample new_spacing", "Resample to this isotropic spacing, trilinear.", float),
    option("--spacing set_spacing", "Set the voxel spacing SZ,SY,SX (z, y, x order) in the "
           "output's metadata; the voxels stay as they are (to change them use --resample)."),
    option("--origin set_origin", "Set the origin OZ,OY,OX (z, y, x order) in the metadata."),
    option("--window", "Clamp values to LO:HI."),
    option("--mask-fill", "Treat this value as 'no data': it joins NaN/Inf in the mask.", float),
    option("--quantize bits", "Floats to N-bit unsigned integers; scale, offset and max error "
           "are recorded.", (1, 32)),
    option("--astype", "Convert the dtype (explicit rounding, out-of-range values clipped and "
           "counted)."),
    option("--rounding", None, ["nearest", "floor", "trunc"], "nearest"),
)  # fmt: skip
@force_option
@json_option
@click.pass_context
def convert(
    ctx,
    source,
    target,
    read_options,
    crop,
    pad_to,
    downsample,
    method,
    isotropic,
    new_spacing,
    set_spacing,
    set_origin,
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
      volpack convert liver.inr liver.nii.gz --shape 165,353,438 --dtype uint8 --offset 256
      volpack convert ct.npy ct.nii.gz --spacing 1.5,0.957,0.957

    Shapes, spacings and origins are given slowest axis first: (z, y, x), x varying
    fastest in the file (zfp and SZ3 list them x first: reverse them).
    """
    from .. import api, prep
    from .. import io as vio

    check_json_output(as_json, target)
    vio.check_outputs(target, force=force, inputs=(source,))
    with phase(ctx, f"reading {source}"):
        vol = api.read_volume(source, **read_options)
    steps = []
    if set_spacing or set_origin:
        vol = vol.replace(
            spacing=_triple(set_spacing, "--spacing", positive=True)
            if set_spacing
            else vol.spacing,
            origin=_triple(set_origin, "--origin") if set_origin else vol.origin,
        )
        steps.append(
            "set "
            + " and ".join(n for n, v in (("spacing", set_spacing), ("origin", set_origin)) if v)
        )
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
        with progress_bar(ctx, "compress") as progress:
            stats = api.compress(vol, target, force=force, progress=progress)
    else:
        with phase(ctx, f"writing {target}"):
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


def _triple(text: str, flag: str, positive: bool = False) -> tuple[float, float, float]:
    import math

    try:
        values = tuple(float(v) for v in text.replace("x", ",").split(","))
    except ValueError:
        values = ()
    if len(values) != 3 or not all(math.isfinite(v) and (v > 0 or not positive) for v in values):
        what = "positive " if positive else ""
        raise click.BadParameter(
            f"expected three {what}numbers Z,Y,X, found {text!r}", param_hint=flag
        )
    return values  # type: ignore[return-value]


def _has_special(vol) -> bool:
    import numpy as np

    return vol.dtype.kind == "f" and not bool(np.isfinite(vol.data).all())


COMMANDS = [convert]
