"""``volpack render``: ray-cast a volume (or a decoded .vpk) into a PNG."""

from __future__ import annotations

import dataclasses
import os
import time

import click

from .options import (
    check_json_output,
    emit_json,
    force_option,
    imports_without_gc,
    json_option,
    phase,
    progress_bar,
    raw_options,
)
from .view import parse_look_at, parse_size, slice_view_option, view_options, wants_slice

# Colour names an isosurface spec may use beside CSS names and #rrggbb.
ISO_COLOURS = {
    "bone": (0.93, 0.88, 0.78),
    "skull": (0.95, 0.92, 0.85),
    "skin": (0.94, 0.72, 0.60),
    "flesh": (0.85, 0.45, 0.40),
    "tissue": (0.85, 0.45, 0.40),
    "vessel": (0.80, 0.10, 0.10),
    "brain": (0.90, 0.75, 0.70),
}


def parse_isos(spec: str) -> list[tuple[float, tuple[float, float, float], float]]:
    """``VALUE:COLOUR[@OPACITY],...`` -> ``[(value, (r, g, b), opacity), ...]``."""
    from PIL import ImageColor

    isos = []
    for item in (s.strip() for s in spec.split(",")):
        if not item:
            continue
        value_s, _, rest = item.partition(":")
        colour_s, _, opacity_s = (rest or "white").partition("@")
        try:
            value = float(value_s)
            opacity = float(opacity_s) if opacity_s else 1.0
        except ValueError:
            raise click.BadParameter(
                f"expected VALUE:COLOUR[@OPACITY], found {item!r}", param_hint="--iso"
            ) from None
        if not 0.0 <= opacity <= 1.0:
            raise click.BadParameter(
                f"expected an opacity in [0, 1], found {opacity_s!r} in {item!r}",
                param_hint="--iso",
            )
        name = colour_s.strip().lower()
        if name in ISO_COLOURS:
            rgb = ISO_COLOURS[name]
        else:
            try:
                rgb = tuple(c / 255 for c in ImageColor.getrgb(name)[:3])
            except ValueError:
                raise click.BadParameter(
                    f"expected a colour name ({', '.join(ISO_COLOURS)}, CSS) or #rrggbb, "
                    f"found {colour_s!r}",
                    param_hint="--iso",
                ) from None
        isos.append((value, rgb, opacity))
    if not isos:
        raise click.BadParameter(f"expected at least one isosurface, found {spec!r}", param_hint="--iso")
    return isos


def _open_octree(source: str):
    """An open :class:`volpack.octree.Octree` when SOURCE is an octree .vpk, else None."""
    from ..format.streams import vpk_kind

    if vpk_kind(source) != "octree":
        return None
    from ..octree import Octree

    return Octree(source, cache_bytes=1 << 30)


def _load_mesh(source: str, field: str | None):
    """``(points, tets, values)`` when SOURCE is a tetrahedral mesh (file or .vpk), else
    None. Vector fields give their magnitude; cell fields are averaged onto the points."""
    import numpy as np

    from . import mesh as mesh_cli

    if mesh_cli.is_mesh_stream(source):
        from ..tetra.stream import decompress_mesh

        m = decompress_mesh(source)
    elif mesh_cli.is_mesh_source(source):
        from ..tetra.formats import read_mesh

        m = read_mesh(source)
    else:
        if field is not None:
            raise click.BadParameter("applies to tetrahedral meshes only", param_hint="--field")
        return None
    names = list(m.point_data) + [n for n in m.cell_data if n not in m.point_data]
    if field is None and not names:  # no field: the shape alone, as a shaded surface
        return np.asarray(m.points, np.float64), m.tets, None, None
    if field is None:
        field = names[0]
    if field in m.point_data:
        v = np.asarray(m.point_data[field], np.float64)
    elif field in m.cell_data:
        c = np.asarray(m.cell_data[field], np.float64).reshape(len(m.tets), -1)
        acc = np.zeros((len(m.points), c.shape[1]))
        cnt = np.zeros(len(m.points))
        for k in range(4):
            np.add.at(acc, m.tets[:, k], c)
            np.add.at(cnt, m.tets[:, k], 1)
        v = acc / np.maximum(cnt, 1)[:, None]
    else:
        raise click.BadParameter(
            f"expected one of {names or 'no fields'}, found {field!r}", param_hint="--field"
        )
    v = v.reshape(len(m.points), -1)
    v = v[:, 0] if v.shape[1] == 1 else np.linalg.norm(v, axis=1)
    return np.asarray(m.points, np.float64), m.tets, v, field


def _load(ctx: click.Context, source: str, frame: int | None, raw: dict):
    """The 3-D Volume to draw: .vpk inputs are decoded, 4-D inputs give one frame."""
    from .. import api
    from .. import io as vio
    from ..volume import Volume, with_fill_masked

    path = vio.parse_spec(source)[0]
    if api.kind_of(path) is not None or path.lower().endswith(".vpk"):  # '-': a .vpk stream too
        with progress_bar(ctx, "decode") as progress:
            vol = api.decompress(path, frame=frame, progress=progress)
    else:
        with phase(ctx, f"reading {source}"):
            vol = vio.read_volume(source, **raw)
    vol = with_fill_masked(vol)  # a netCDF's _FillValue is no data: empty, as NaN is
    if vol.data.ndim == 4:
        t = frame or 0
        if not 0 <= t < vol.data.shape[0]:
            raise click.BadParameter(
                f"expected a frame in 0..{vol.data.shape[0] - 1}, found {t}", param_hint="--frame"
            )
        mask = None if vol.mask is None else vol.mask[t]
        vol = Volume(vol.data[t], spacing=vol.spacing, origin=vol.origin, mask=mask)
    return vol


@click.command(context_settings={"help_option_names": ["-h", "--help"]})
@click.argument("source")
@click.argument("output")
@click.option("--tf", "tf_spec", help="Transfer function: a preset (ct-bone, ct-skin, ct-soft, "
              "mri, generic), 'auto' (chosen from the histogram: CT, labels or an Otsu "
              "threshold) or a JSON file. Default: auto, or none with --iso; without a --tf, "
              "a mesh is drawn as its lit boundary surface, coloured by --field.")  # fmt: skip
@view_options
@click.option("--iso", "iso_spec", help="Isosurfaces VALUE:COLOUR[@OPACITY],... e.g. "
              "300:bone,1200:skull@0.4 (COLOUR: a name or #rrggbb).")  # fmt: skip
@click.option("--orbit", type=click.IntRange(min=1), help="Render N views around the volume; "
              "OUTPUT is then a folder of frame_000.png ...")  # fmt: skip
@slice_view_option
@click.option("--colorbar", is_flag=True, help="Draw the transfer function under the image.")
@click.option("--frame", type=click.IntRange(min=0), help="Time step of a 4-D input (default 0).")
@click.option("--field", help="Tetrahedral meshes: the point or cell field to draw (default the "
              "first point field; cell fields are averaged onto the points).")  # fmt: skip
@click.option("--budget", type=click.IntRange(min=1), help="Octree .vpk: draw at most this many "
              "nodes' worth of voxels, chosen for the view (default 2048; the thesis used "
              "2048/1024/512).")  # fmt: skip
@click.option("-j", "--workers", type=click.IntRange(min=0), default=0, show_default=True,
              help="Threads (0 = every core). The image does not depend on it.")  # fmt: skip
@raw_options
@force_option
@json_option
@click.pass_context
def render(
    ctx,
    source,
    output,
    tf_spec,
    azimuth,
    elevation,
    zoom,
    perspective,
    distance,
    look_at_s,
    size_s,
    step,
    classification,
    preint_method,
    shading,
    normals,
    fit,
    iso_spec,
    orbit,
    view_mode,
    colorbar,
    frame,
    field,
    budget,
    workers,
    read_options,
    force,
    as_json,
) -> None:
    """Ray-cast the volume or tetrahedral mesh SOURCE (any readable volume, mesh file or
    .vpk) into OUTPUT.png.

    Front-to-back compositing with pre-integrated classification and Phong shading by
    default, the transfer function chosen from the data's histogram and the camera
    framed on what it shows (80 % of the image). Background black. A mesh is drawn as
    its lit boundary surface; given a --tf, it is ray cast cell by cell through its face
    graph, each cell's piece of ray integrated exactly (the field is linear inside a
    tetrahedron).

    \b
    Examples:
      volpack render head.nii.gz head.png
      volpack render ct.vpk ct.png --tf ct-bone --azimuth 90 --elevation 10 --colorbar
      volpack render ct.nrrd bones.png --iso 300:bone,1200:skull@0.4
      volpack render mri.npy mri.png --classification post --step 0.25 --size 800x600
      volpack render ct.npy ct.png --tf ct-bone --preint exact --shading preintegrated
      volpack render ct.nii.gz orbit/ --orbit 36 --perspective --zoom 1.3
      volpack render ct.nii.gz inside.png --perspective --distance 20   # from inside
      volpack render mesh.vpk mesh.png --field temperature --tf generic
      volpack render big.vpk big.png --budget 2048 --tf ct-bone    # octree: level of detail
      volpack render slice.dcm slice.png            # one slice: drawn as the image it is
      volpack render ct.nii.gz mid.png --view slice --colorbar   # the middle axial slice
    """
    with imports_without_gc():
        import numpy as np

        from ..errors import OptionError
        from ..format.atomic import check_output
        from ..io import parse_spec
        from ..render import transfer
        from ..render.autotf import transfer_for
        from ..render.camera import Camera
        from ..render.image import save_png
        from ..render.raycast import RenderStats
        from ..render.raycast import render as raycast

    size = parse_size(size_s)
    isos = parse_isos(iso_spec) if iso_spec else None
    check_json_output(as_json, output)
    if orbit:
        if os.path.exists(output) and not os.path.isdir(output):
            raise click.BadParameter(f"expected a folder with --orbit, found the file {output!r}")
        targets = [os.path.join(output, f"frame_{k:03d}.png") for k in range(orbit)]
    else:
        if output != "-" and not output.lower().endswith(".png"):  # PNG bytes, whatever the name
            raise OptionError(
                f"expected an OUTPUT ending in .png (or '-', or a folder with --orbit), "
                f"found {output!r}"
            )
        targets = [output]
    inputs = (parse_spec(source)[0],)
    for t in targets:
        check_output(t, force=force, inputs=inputs)

    tree = _open_octree(source)
    if tree is not None:
        ctx.call_on_close(tree.close)
    elif budget is not None:
        raise click.BadParameter("applies to octree .vpk files only", param_hint="--budget")
    mesh = None if tree is not None else _load_mesh(source, field)
    ok = None  # the values that count for the range: None for all of them
    if tree is not None:
        from ..render.lod import tree_range

        lo, hi = tree_range(tree)
        data = np.array([lo, hi], dtype=tree.dtype)
    elif mesh is not None:
        if isos:
            raise click.BadParameter("isosurfaces are drawn for volumes only", param_hint="--iso")
        points, cells, data, field = mesh
        if data is None and tf_spec is not None:
            raise click.BadParameter("expected a mesh with a point or cell field, found none",
                                     param_hint="--tf")  # fmt: skip
        data = np.zeros(len(points)) if data is None else data
    else:
        vol = _load(ctx, source, frame, read_options)
        data = vol.data
        ok = np.isfinite(data) if data.dtype.kind == "f" else None
        if vol.mask is not None:
            ok = ~vol.mask if ok is None else ok & ~vol.mask
    slice_view = (mesh is None and tree is None
                  and wants_slice(ctx, view_mode, data.shape, three_d=bool(isos or orbit)))  # fmt: skip
    if view_mode == "slice" and not slice_view:
        raise click.BadParameter("expected a volume (not a mesh or octree) and no --iso or "
                                 "--orbit", param_hint="--view slice")  # fmt: skip
    with phase(ctx, "preparing the render (value range, transfer function, framing, gradients)"):
        if ok is None and data.size:  # no copy of the selected values (16 ms of a CT)
            lo, hi = float(data.min()), float(data.max())
        elif ok is not None and ok.any():
            lo, hi = float(data[ok].min()), float(data[ok].max())
        else:
            lo, hi = 0.0, 1.0
        lo, hi = transfer.nonempty_range(lo, hi)
        sample, factor = (vol if mesh is None and tree is None else None), 1
        if tree is not None:
            from ..render.lod import coarse_level

            sample, factor = coarse_level(tree)
        tf = None
        if slice_view:
            from ..render.slice import slice_axis, slice_transfer

            axis = slice_axis(data.shape)
            slice_at = {"axis": axis, "index": data.shape[axis] // 2}
        if slice_view and tf_spec in (None, "auto"):
            tf = slice_transfer(data, dtype=data.dtype, mask=vol.mask, value_range=(lo, hi))
        elif mesh is not None and tf_spec is None:
            pass  # a mesh without --tf is drawn as its shaded boundary surface
        elif tf_spec is not None or not isos:
            tf = transfer_for(tf_spec, data if sample is None else sample.data, lo=lo, hi=hi,
                              dtype=data.dtype, mask=None if sample is None else sample.mask,
                              size=256 if mesh is not None else max(data.shape if tree is None else tree.shape))  # fmt: skip

        azimuths = [azimuth + 360.0 * k / orbit for k in range(orbit)] if orbit else [azimuth]
        view = Camera(
            azimuth=azimuth, elevation=elevation, zoom=zoom, size=size, distance=distance,
            projection="perspective" if perspective else "orthographic",
            look_at=parse_look_at(look_at_s),
        )  # fmt: skip
        if slice_view:
            pass  # drawn face-on, fitted to the image
        elif fit and mesh is not None:
            from ..render.tetra import fit_mesh_camera

            view = fit_mesh_camera(view, points, cells, azimuths=azimuths if orbit else None)
        elif fit:
            from ..render.framing import fit_camera

            view = fit_camera(
                view, sample.data, tf, lo, hi, spacing=sample.spacing if tree is None else tree.spacing,
                shape=tree.shape if tree is not None else None, factor=factor, mask=sample.mask,
                isos=isos,
                azimuths=azimuths if orbit else None,
            )  # fmt: skip
        if orbit:
            os.makedirs(output, exist_ok=True)
        if mesh is None and tree is None and not slice_view:  # sampled array, gradients, ...
            from ..render.prepared import prepare_volume

            vol = prepare_volume(vol)

    lod_frames = []
    lod_atlas = []  # one NodeAtlas (decoded nodes, gradient bricks) for every view

    def draw(cam, progress_rows):
        if tree is not None:
            from ..render.lod import NodeAtlas, render_lod

            if not lod_atlas:
                lod_atlas.append(NodeAtlas(tree, gradients=shading != "none"))
            t0 = time.perf_counter()
            img, lst = render_lod(
                tree, tf=tf, camera=cam, blocks=budget or 2048, value_range=(lo, hi),
                atlas=lod_atlas[0], step=step, classification=classification, shading=shading,
                normals=normals, preint_method=preint_method, workers=workers,
                progress=progress_rows,
            )  # fmt: skip
            lod_frames.append(vars(lst))
            return img, RenderStats(0, time.perf_counter() - t0, cam.size[0] * cam.size[1], 0)
        if slice_view:
            from ..render.slice import render_slice

            t0 = time.perf_counter()
            img = render_slice(vol, tf, value_range=(lo, hi), size=cam.size, zoom=zoom,
                               nearest=tf.name == "auto-labels", **slice_at)  # fmt: skip
            return img, RenderStats(0, time.perf_counter() - t0, cam.size[0] * cam.size[1], 0)
        if mesh is not None and tf is None:
            from ..render.tetra import render_surface

            return render_surface(
                points, cells, data if field is not None else None, camera=cam,
                value_range=(lo, hi), workers=workers, render_stats=True,
            )  # fmt: skip
        if mesh is not None:
            from ..render.tetra import render_mesh

            return render_mesh(
                points, cells, data, tf=tf, camera=cam, value_range=(lo, hi),
                shading="none" if shading == "none" else "phong", workers=workers,
                progress=progress_rows, render_stats=True,
            )  # fmt: skip
        return raycast(
            vol, tf=tf, camera=cam, step=step, classification=classification, shading=shading,
            normals=normals, isos=isos, preint_method=preint_method, value_range=(lo, hi),
            workers=workers,
            progress=progress_rows, render_stats=True,
        )  # fmt: skip

    frames = []
    samples, seconds = 0, 0.0
    with progress_bar(ctx, "render", unit="frame" if orbit else "row") as progress:
        for k, target in enumerate(targets):
            cam = dataclasses.replace(view, azimuth=azimuths[k])
            img, stats = draw(cam, None if (orbit or progress is None) else progress)
            save_png(target, img, colorbar=(tf, lo, hi) if (colorbar and tf) else None, force=force)
            samples += stats.samples
            seconds += stats.seconds
            frames.append({"path": target, "azimuth": cam.azimuth, "seconds": stats.seconds})
            if orbit and progress is not None:
                progress(k + 1, orbit)
    report = {
        "output": output,
        "view": "slice" if slice_view else "volume",
        "slice": slice_at if slice_view else None,
        "frames": frames,
        "size": list(size),
        "shape": list(tree.shape if tree is not None else data.shape) if mesh is None else None,
        "lod": lod_frames or None,
        "mesh": None
        if mesh is None
        else {"points": len(points), "tets": len(cells), "field": field},
        "value_range": [lo, hi],
        "tf": tf.name if tf is not None else None,
        "isos": [{"value": v, "rgb": list(c), "opacity": a} for v, c, a in (isos or [])],
        "classification": classification,
        "shading": shading,
        "normals": normals,
        "step": step,
        "samples": samples,
        "seconds": seconds,
        "samples_per_s": samples / seconds if seconds > 0 else None,
    }
    if as_json:
        emit_json(report)
    else:
        what = f"{len(frames)} frames in {output}" if orbit else output
        if slice_view:
            click.echo(f"{what}: {size[0]}x{size[1]}, slice {slice_at['index']} across axis "
                       f"{slice_at['axis']} drawn face-on, tf {report['tf']}", err=True)  # fmt: skip
            return
        click.echo(
            f"{what}: {size[0]}x{size[1]}, {classification}, {shading}, "
            f"tf {report['tf'] or 'none'}, {seconds:.2f} s, "
            f"{samples / max(seconds, 1e-9) / 1e6:.1f} M samples/s",
            err=True,
        )


COMMANDS = [render]
