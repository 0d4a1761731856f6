"""The camera and ray-casting options that ``render``, ``play`` and ``walk`` share, and
their parsers (apart from :mod:`.render`, so that ``play`` and ``walk`` do not compile
the render command's module)."""

from __future__ import annotations

import click


def parse_look_at(value: str | None) -> tuple[float, float, float] | None:
    if value is None:
        return None
    try:
        z, y, x = (float(v) for v in value.split(","))
    except ValueError:
        raise click.BadParameter(
            f"expected Z,Y,X, found {value!r}", param_hint="--look-at"
        ) from None
    return z, y, x


def parse_size(value: str) -> tuple[int, int]:
    try:
        w, h = (int(v) for v in value.lower().replace(",", "x").split("x"))
    except ValueError:
        raise click.BadParameter(f"expected WxH, found {value!r}", param_hint="--size") from None
    if not (1 <= w <= 16384 and 1 <= h <= 16384):
        raise click.BadParameter(f"expected 1..16384 per side, found {value!r}", param_hint="--size")
    return w, h


def view_options(f):
    """Camera and ray-casting options shared by ``render``, ``play`` and ``walk``."""
    opts = [
        click.option("--azimuth", type=float, default=30.0, show_default=True,
                     help="Degrees about z."),
        click.option("--elevation", type=float, default=20.0, show_default=True,
                     help="Degrees up."),
        click.option("--zoom", type=click.FloatRange(min=0, min_open=True), default=1.0,
                     show_default=True),
        click.option("--perspective", is_flag=True,
                     help="Perspective projection (30 degree field)."),
        click.option("--distance", type=click.FloatRange(min=0), help="Eye (perspective) or "
                     "near plane (orthographic) distance from the volume centre, in spacing "
                     "units; small values put the camera inside the volume. Default: outside."),
        click.option("--look-at", "look_at_s", help="Orbit centre Z,Y,X in voxel indices "
                     "(meshes: in their units; default the centre of what is shown)."),
        click.option("--size", "size_s", default="512x512", show_default=True,
                     help="Image WxH."),
        click.option("--step", type=click.FloatRange(min=0.01), default=0.5, show_default=True,
                     help="Ray step in voxels (of the smallest spacing), at least 0.01 "
                     "(0.01 takes about 50x the default's time)."),
        click.option("--classification", type=click.Choice(["preintegrated", "post", "pre"]),
                     default="preintegrated", show_default=True,
                     help="Where the TF is applied: pre-integrated segments, samples, or voxels."),
        click.option("--preint", "preint_method", type=click.Choice(["fast", "exact"]),
                     default="fast", show_default=True,
                     help="Pre-integration table: fast (no self-attenuation) or exact."),
        click.option("--shading", type=click.Choice(["phong", "centroid", "preintegrated", "none"]),
                     default="phong", show_default=True, help="phong: a headlight at the "
                     "segment midpoint; centroid: at the segment's emission centroid (most "
                     "accurate); preintegrated: lighting tables, n.l linear along the segment. "
                     "The last two need --classification preintegrated."),
        click.option("--normals", type=click.Choice(["quantised", "exact"]),
                     default="quantised", show_default=True,
                     help="Phong normals of orthographic views: per-voxel 16-bit "
                     "quantised normals lit through one table per frame (faster), or the "
                     "central differences of the interpolated field at each sample (as "
                     "perspective views always use)."),
        click.option("--fit/--no-fit", default=True, show_default=True,
                     help="Frame what the transfer function shows so that it spans 80 % of "
                     "the image (--zoom multiplies that), or the whole grid (--no-fit)."),
    ]  # fmt: skip
    for opt in reversed(opts):
        f = opt(f)
    return f


#: Options that ask for a 3-D view; given any, ``--view auto`` ray casts even a slice.
CAMERA_OPTIONS = ("azimuth", "elevation", "perspective", "distance", "look_at_s")


def slice_view_option(f):
    """``--view auto|volume|slice`` (``render`` and ``play``)."""
    return click.option(
        "--view", "view_mode", type=click.Choice(["auto", "volume", "slice"]), default="auto",
        show_default=True, help="volume: ray cast; slice: draw one slice face-on as a 2-D "
        "image (the first axis of length 1, else the middle slice of the shortest axis; a "
        "transfer function given colours it, opacity scaled to its largest; without one, "
        "scans in grey and fields in a colour map over the 0.5-99.8th percentiles; --size, "
        "--zoom and render's --colorbar apply); auto: slice for a volume one voxel thick drawn without "
        "camera options, else volume.",
    )(f)  # fmt: skip


def wants_slice(ctx: click.Context, mode: str, shape, *, three_d: bool) -> bool:
    """Whether ``--view`` (``mode``) draws a slice: asked for, or ``auto`` on a volume one
    voxel thick that no camera option asks to see in 3-D (``three_d``: isosurfaces, an
    orbit or a spin ask for it too)."""
    if mode != "auto":
        return mode == "slice" and not three_d
    from click.core import ParameterSource

    default = all(ctx.get_parameter_source(p) in (ParameterSource.DEFAULT, None)
                  for p in CAMERA_OPTIONS)  # fmt: skip
    return 1 in tuple(shape) and not three_d and default
