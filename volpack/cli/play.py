"""``volpack play``: decode an animation on its playback schedule and render every frame."""

from __future__ import annotations

import click

from .options import (
    emit_json,
    force_option,
    imports_without_gc,
    json_option,
    progress_bar,
    table,
)
from .view import parse_look_at, parse_size, slice_view_option, view_options, wants_slice


@click.command(context_settings={"help_option_names": ["-h", "--help"]})
@click.argument("source")
@click.argument("output", required=False)
@click.option("--tf", "tf_spec", help="Transfer function: a preset (ct-bone, ct-skin, ct-soft, "
              "mri, generic), 'auto' or a JSON file. Default: auto, chosen from the first "
              "frame's histogram and fixed for the whole animation.")  # fmt: skip
@click.option("--fps", type=click.FloatRange(min=0, min_open=True, max=1000), default=25.0,
              show_default=True, help="Frames per second of the movie.")  # fmt: skip
@click.option("--spin", type=float, default=0.0, show_default=True,
              help="Degrees the camera turns about z per frame.")  # fmt: skip
@click.option("--stats", "show_stats", is_flag=True, help="Print a per-frame table: type, "
              "bytes, decode and render milliseconds.")  # fmt: skip
@view_options
@slice_view_option
@click.option("-j", "--workers", type=click.IntRange(min=0), default=0, show_default=True,
              help="Render threads (0 = every core).")  # fmt: skip
@force_option
@json_option
@click.pass_context
def play(ctx, source, output, tf_spec, fps, spin, show_stats, azimuth, elevation, zoom,
         perspective, distance, look_at_s, size_s, step, classification, preint_method, shading,
         normals, fit, view_mode, workers, force, as_json) -> None:  # fmt: skip
    """Play the animation SOURCE (.vpk, or '-') into OUTPUT: an .mp4, a .gif or a folder of
    PNGs; without OUTPUT, decode and render only (with --stats: a timing table). SOURCE
    may also be a 4-D (t, z, y, x) series: a volume .vpk or any 4-D volume file (an fMRI
    .nii.gz, a .npy), played a time step a frame; a netCDF variable whose first dimension
    is time, (time, lat, lon), plays as 2-D fields drawn face-on, its declared fill value
    empty.

    Frames are decoded in storage order, one per displayed frame after the first (two
    before it), exactly as a player keeps up with a stream; a damaged stream plays up to
    the damage, then stops with an error naming the frame. A series stored frame by frame
    decodes a time step a frame; one stored interleaved, or another file, is read whole
    before the first.

    \b
    Examples:
      volpack play run.vpk run.mp4 --tf ct-skin --fps 25
      volpack play run.vpk run.gif --size 256x256 --spin 3
      volpack play run.vpk --stats
      volpack play bold.nii.gz bold.gif --tf mri --fps 5     # an fMRI run's time steps
      volpack play sst.nc sst.gif          # a netCDF (time, lat, lon): 2-D fields, face-on
    """
    import dataclasses

    with imports_without_gc():
        import numpy as np

        from ..animation import player
        from ..format.atomic import check_output
        from ..render.autotf import transfer_for
        from ..render.camera import Camera
        from ..render.framing import fit_camera
        from ..render.raycast import render as raycast
        from ..render.slice import render_slice, slice_transfer

    size = parse_size(size_s)
    if view_mode == "slice" and spin:
        raise click.BadParameter("expected no --spin", param_hint="--view slice")
    if output is not None and not _is_folder(output):
        check_output(output, force=force, inputs=(source,))
    vr = player.recorded_range(source) if source != "-" else None
    n_frames = player.frame_count(source) if source != "-" else None
    fill = player.declared_fill_of(source)  # no data: drawn empty, as NaN is
    state: dict = {"tf": None, "range": vr, "k": 0}

    def render(frame: np.ndarray) -> np.ndarray:
        if fill is not None and frame.dtype.kind == "f":
            frame = np.where(frame == frame.dtype.type(fill), frame.dtype.type(np.nan), frame)
        if state["tf"] is None:  # the first frame sets the TF and the framing for all
            lo, hi = state["range"] or (float(np.nanmin(frame)), float(np.nanmax(frame)))
            hi = hi if hi > lo else lo + 1.0
            state["range"] = (lo, hi)
            state["slice"] = wants_slice(ctx, view_mode, frame.shape, three_d=bool(spin))
            if state["slice"] and tf_spec in (None, "auto"):
                state["tf"] = slice_transfer(frame, value_range=(lo, hi))
            else:
                state["tf"] = transfer_for(tf_spec, frame, lo=lo, hi=hi, dtype=frame.dtype)
            view = Camera(azimuth=azimuth, elevation=elevation, zoom=zoom, size=size,
                          projection="perspective" if perspective else "orthographic",
                          distance=distance, look_at=parse_look_at(look_at_s))  # fmt: skip
            turn = [azimuth + 15.0 * k for k in range(24)] if spin else None
            state["view"] = (
                fit_camera(view, frame, state["tf"], lo, hi, azimuths=turn)
                if fit and not state["slice"] else view
            )  # fmt: skip
        if state["slice"]:
            return render_slice(frame, state["tf"], value_range=state["range"], size=size,
                                zoom=zoom, nearest=state["tf"].name == "auto-labels")  # fmt: skip
        cam = dataclasses.replace(state["view"], azimuth=azimuth + spin * state["k"])
        state["k"] += 1
        return raycast(
            frame, tf=state["tf"], camera=cam, step=step,
            classification=classification, shading=shading, normals=normals,
            preint_method=preint_method, value_range=state["range"], workers=workers,
        )  # fmt: skip

    rows = []
    with _movie(output, fps, force) as writer, progress_bar(ctx, "play", unit="frame") as progress:
        for img, st in player.play_rendered(source, render):
            if writer is not None:
                writer.write(img)
            rows.append(st)
            if progress is not None:
                progress(len(rows), n_frames)
    dec = sum(r.decode_ms for r in rows) / 1000
    ren = sum(r.render_ms for r in rows) / 1000
    report = {
        "output": output,
        "frames": len(rows),
        "value_range": list(state["range"]) if state["range"] else None,
        "tf": state["tf"].name if state["tf"] is not None else None,
        "view": None if state["tf"] is None else "slice" if state["slice"] else "volume",
        "decode_fps": len(rows) / dec if dec > 0 else None,
        "render_fps": len(rows) / ren if ren > 0 else None,
        "fps": len(rows) / (dec + ren) if dec + ren > 0 else None,
        "per_frame": [vars(r) for r in rows],
    }
    if as_json:
        emit_json(report)
        return
    if show_stats:
        click.echo(table([[r.t, r.type, r.nbytes, f"{r.decode_ms:.1f}", f"{r.render_ms:.1f}"]
                          for r in rows], ["frame", "type", "bytes", "decode ms", "render ms"]))  # fmt: skip
    click.echo(
        f"{output or source}: {len(rows)} frames, decode {report['decode_fps'] or 0:.1f} "
        f"frames/s, render {report['render_fps'] or 0:.1f} frames/s",
        err=True,
    )


def _movie(output, fps: float, force: bool):
    """A :class:`~volpack.render.movie.MovieWriter` for OUTPUT (finished on success,
    discarded on error), or a stand-in yielding None when there is no OUTPUT."""
    import contextlib

    from ..render.movie import MovieWriter

    return contextlib.nullcontext() if output is None else MovieWriter(output, fps=fps, force=force)


def since_start() -> float | None:
    """Seconds since the user's process started (what a user waits for a frame, imports
    included; 10 ms resolution, from /proc): the client's when a server runs the
    command (:func:`volpack.serve.started`); None where there is no /proc."""
    import time

    from ..serve import started

    t0 = started()
    if t0 is None:
        return None
    try:
        return time.clock_gettime(time.CLOCK_BOOTTIME) - t0
    except (OSError, AttributeError):
        return None


def _is_folder(path: str) -> bool:
    from ..render.movie import movie_kind

    return movie_kind(path) == "png"


def _ahead(fn, *args, inline: bool = False):
    """A future of ``fn(*args)``: run on a helper thread, or here and now with
    ``inline``; its ``result()`` raises ``fn``'s exception here."""
    from concurrent.futures import Future, ThreadPoolExecutor

    if not inline:
        pool = ThreadPoolExecutor(1, thread_name_prefix="volpack-ahead")
        future = pool.submit(fn, *args)
        pool.shutdown(wait=False)  # (the task runs on; the thread ends after it)
        return future
    future = Future()
    try:
        future.set_result(fn(*args))
    except BaseException as e:  # re-raised by result()
        future.set_exception(e)
    return future


def _coarse(tree):
    """:func:`~volpack.render.lod.coarse_level` of ``tree`` (its module imported here)."""
    from ..render.lod import coarse_level

    return coarse_level(tree)


@click.command(context_settings={"help_option_names": ["-h", "--help"]})
@click.argument("source")
@click.argument("output", required=False)
@click.option("--orbit", type=click.IntRange(min=1), default=36, show_default=True,
              help="Frames on a full turn about z.")  # fmt: skip
@click.option("--budget", type=click.IntRange(min=1), default=1024, show_default=True,
              help="Nodes drawn per frame, chosen for each view.")  # fmt: skip
@click.option("--decode-budget", type=click.IntRange(min=0), default=0, show_default=True,
              help="Nodes decoded per frame at most (0: no limit). The first frames draw "
              "the coarsest nodes this allows and refine over the next ones, which then "
              "cost more than a settled frame (64 on a 1039-node MRI: its first frame "
              "decodes less but ray casts as long, the next two take about twice a "
              "settled one); once a frame holds nothing back ('held' 0 in --stats) every "
              "view is drawn as without a limit.")  # fmt: skip
@click.option("--tf", "tf_spec", help="Transfer function: a preset, 'auto' or a JSON file.")
@click.option("--fps", type=click.FloatRange(min=0, min_open=True, max=1000), default=25.0,
              show_default=True)  # fmt: skip
@click.option("--compare", is_flag=True, help="Also render the full-resolution volume for "
              "every view and report the image error (decodes the whole volume once).")  # fmt: skip
@click.option("--stats", "show_stats", is_flag=True, help="Print a per-frame table.")
@view_options
@click.option("-j", "--workers", type=click.IntRange(min=0), default=0, show_default=True)
@force_option
@json_option
@click.pass_context
def walk(ctx, source, output, orbit, budget, decode_budget, tf_spec, fps, compare, show_stats, azimuth,
         elevation, zoom, perspective, distance, look_at_s, size_s, step, classification, preint_method,
         shading, normals, fit, workers, force, as_json) -> None:  # fmt: skip
    """Fly around the octree SOURCE (.vpk built with --octree) into OUTPUT (.mp4, .gif or a
    folder), drawing each view from the nodes it needs within --budget.

    Decoded nodes stay in a cache across frames, so a frame decodes only the nodes the
    previous views did not need; with --decode-budget at most that many, so the first
    frame comes sooner from coarser nodes and the next ones sharpen it. --stats shows
    nodes drawn and decoded, refinements held back, bytes read and the time split per
    frame.

    \b
    Examples:
      volpack walk big.vpk walk.mp4 --orbit 120 --budget 1024 --tf ct-bone
      volpack walk big.vpk --orbit 12 --budget 256 --compare --stats
      volpack walk big.vpk walk.mp4 --decode-budget 64   # a quicker, coarser first frame
      volpack walk big.vpk fly/ --perspective --distance 60 --orbit 48   # through the volume
    """
    import contextlib
    import dataclasses
    import math

    with imports_without_gc():  # numba among them
        import numpy as np

        from ..format.atomic import check_output
        from ..octree import Octree
        from ..parallel import parse_workers

    size = parse_size(size_s)
    if output is not None and not _is_folder(output):
        check_output(output, force=force, inputs=(source,))
    opts = dict(step=step, classification=classification, shading=shading, normals=normals,
                preint_method=preint_method, workers=workers)  # fmt: skip
    rows = []
    with Octree(source, cache_bytes=1 << 30) as tree, contextlib.ExitStack() as paused:
        # up to the first frame, the collector is paused (imports_without_gc) here and on
        # the helper threads: their imports and kernel loads make many objects and no
        # garbage (on the MRI's walk 43-94 ms of collections went before the first frame,
        # and a full one of 34-40 ms into it)
        paused.enter_context(imports_without_gc())
        # the coarse level (for the TF and the framing) decodes on a helper thread while
        # this one imports the renderer: a fresh process's first kernel loads and chunk
        # decodes there run without the GIL, the imports here hold it (one worker: here)
        coarse = _ahead(_coarse, tree, inline=parse_workers(workers) < 2)
        from ..render.autotf import transfer_for
        from ..render.camera import Camera
        from ..render.framing import fit_camera
        from ..render.lod import NodeAtlas, render_lod, tree_range
        from ..render.prepared import prepare_volume
        from ..render.raycast import render as raycast
        from ..render.rehearse import rehearse

        lo, hi = tree_range(tree)
        # decoded nodes and their gradient bricks, kept while they stay in view; the first
        # frame's grid and normal codes are made on a helper thread meanwhile
        atlas = NodeAtlas(tree, gradients=shading != "none")
        atlas.reserve((lo, hi), workers=workers, codes=shading == "phong" and normals == "quantised"
                      and not perspective and classification != "pre")  # fmt: skip
        # and the first frame's chunk scans, write and render kernels loaded on another
        rehearsal = rehearse(atlas, (lo, hi), opts, perspective, workers)
        if not coarse.done():  # this thread would wait: Pillow's set-up for the frames now
            from ..render.image import ready_png

            ready_png()
        sample, factor = coarse.result()
        tf = transfer_for(tf_spec, sample.data, lo=lo, hi=hi, dtype=tree.dtype,
                          mask=sample.mask, size=max(tree.shape))  # fmt: skip
        azimuths = [azimuth + 360.0 * k / orbit for k in range(orbit)]
        view = Camera(azimuth=azimuth, elevation=elevation, zoom=zoom, size=size,
                      distance=distance, look_at=parse_look_at(look_at_s),
                      projection="perspective" if perspective else "orthographic")  # fmt: skip
        if fit:
            view = fit_camera(view, sample.data, tf, lo, hi, spacing=tree.spacing,
                              shape=tree.shape, factor=factor, mask=sample.mask,
                              azimuths=azimuths)  # fmt: skip
        full = prepare_volume(tree.decode(0).data) if compare else None
        with (
            _movie(output, fps, force) as writer,
            progress_bar(ctx, "walk", unit="frame") as progress,
        ):
            if rehearsal is not None:  # done by now, or the frame would wait on its loads
                rehearsal.wait()
            paused.close()  # what was made so far frozen (a whole process), collected as usual
            # the coarse level (and with --compare the whole volume) was decoded before the
            # frames: on a small tree every node the frames draw, so they decode none
            ahead = tree.decoded_nodes
            for k in range(orbit):
                cam = dataclasses.replace(view, azimuth=azimuths[k])
                img, st = render_lod(tree, tf=tf, camera=cam, blocks=budget,
                                     value_range=(lo, hi), atlas=atlas,
                                     decode=decode_budget or None, **opts)  # fmt: skip
                row = {"frame": k, "azimuth": cam.azimuth, **vars(st),
                       "finished_at": since_start()}  # fmt: skip
                if full is not None:
                    ref = raycast(full, tf=tf, camera=cam, value_range=(lo, hi), **opts)
                    rmse = float(np.sqrt(np.mean((img[..., :3] - ref[..., :3]) ** 2)))
                    row["rmse"] = rmse
                    row["psnr"] = 20 * math.log10(1 / rmse) if rmse > 0 else None
                rows.append(row)
                if writer is not None:
                    writer.write(img)
                if progress is not None:
                    progress(k + 1, orbit)
    secs = sum(r["select_s"] + r["decode_s"] + r["render_s"] for r in rows)
    report = {"output": output, "frames": len(rows), "budget": budget,
              "decode_budget": decode_budget, "tf": tf.name, "decoded_before": ahead,
              "fps": len(rows) / secs if secs > 0 else None, "per_frame": rows}  # fmt: skip
    if as_json:
        emit_json(report)
        return
    if show_stats:
        head = ["frame", "nodes", "decoded", "held", "bytes", "select ms", "decode ms",
                "render ms"]  # fmt: skip
        head += ["PSNR dB"] if compare else []
        click.echo(table([[r["frame"], r["nodes"], r["decoded"], r["held"], r["bytes_read"],
                           f"{1000 * r['select_s']:.1f}", f"{1000 * r['decode_s']:.1f}",
                           f"{1000 * r['render_s']:.1f}"]
                          + ([f"{r['psnr']:.2f}" if r.get("psnr") else "inf"] if compare else [])
                          for r in rows], head))  # fmt: skip
    held = [r["frame"] for r in rows if r["held"]]
    click.echo(f"{output or source}: {len(rows)} frames, {report['fps'] or 0:.2f} frames/s, "
               f"{sum(r['decoded'] for r in rows)} nodes decoded"
               + (f" in the frames, {ahead} before them (the coarse level for the transfer "
                  "function and framing" + (", the whole volume for --compare" if compare else "")
                  + ")" if ahead else "")
               + (f", refinement held back by --decode-budget on frames {held[0]}-{held[-1]}"
                  if held else ""), err=True)  # fmt: skip


COMMANDS = [play, walk]
