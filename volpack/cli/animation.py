"""The animation side of ``volpack compress`` and ``volpack info``: options, the call into
:mod:`volpack.animation`, and the per-frame table.

``compress`` takes the path into animations when ``--gop`` is given or SOURCE is a glob
pattern of frame files; without them it behaves as before (4-D input coded frame by
frame, each independently).
"""

from __future__ import annotations

import click

from .options import db, fmt_bytes, fmt_speed, option, options, table

animation_options = options(
    option("--gop",
           "Code SOURCE as an animation with this group of pictures, e.g. IBBPBBPBB (I: alone, "
           "P: from the previous anchor, B: from both neighbouring anchors), IPP, or I (every "
           "frame alone). SOURCE is 4-D (t, z, y, x) or a quoted glob of 3-D files "
           "('frames/*.npy', natural name order)."),
    option("--search", "Animation: motion search range, voxels per axis.", (0, 64), 15),
    option("--motion", "Animation: fast search from the zero vector, or every whole-voxel "
           "vector.", ["fast", "exhaustive"], "fast"),
    option("--half-voxel/--no-half-voxel", "Animation: refine vectors to half voxels "
           "(interpolated reference).", None, True),
    option("--quarter-voxel/--no-quarter-voxel", "Animation: refine vectors further, to "
           "quarter voxels (needs --half-voxel; except with --quality each frame keeps the "
           "half- or quarter-voxel field costing less).", None, True),
    option("--compensation", "Animation: overlapping 12^3 cosine windows, or plain 8^3 "
           "blocks.", ["windowed", "block"], "windowed"),
    option("--b-residual/--no-b-residual", "Animation: code B-frames' residual (needed for "
           "--max-error; without it B-frames are motion compensation only, as in the thesis, "
           "with --quality).", None, True),
    option("--whole-frame/--no-whole-frame", "Animation: where the blocks move as one (a "
           "rigid translation), also try moving the whole anchor through its spectrum (no "
           "blur at sub-voxel steps; 8/16-bit frames, lossless or --max-error).", None, True),
    option("--i-max-error",
           "Animation with --max-error: the bound of I-frames that anchor P/B-frames. "
           "Predicted frames inherit their anchors' error, so cleaner anchors can make them "
           "cheaper [default: 2/3 of --max-error (floored for integer voxels, at least 1), "
           "kept if the first GOP segment coded both ways says it pays]; give the "
           "--max-error value to code every frame to it.",
           click.FloatRange(min=0, min_open=True)),
)  # fmt: skip
"""The animation options of ``volpack compress``."""


def wants_animation(source: str, gop: str | None) -> bool:
    """``--gop`` given, or SOURCE a glob pattern (the same test as
    :func:`volpack.animation.frames.is_pattern`, without importing the codecs)."""
    return gop is not None or any(c in source for c in "*?[")


def animation_compress_options(extra: dict) -> dict:
    """The animation options of ``volpack compress`` as :func:`volpack.animation.stream.compress`
    names them (``--no-half-voxel`` means whole voxels: quarter voxels refine half ones)."""
    precision = (
        "whole" if not extra["half_voxel"] else "quarter" if extra["quarter_voxel"] else "half"
    )
    return {
        "gop_string": extra["gop"] or "IBBPBBPBB",
        "search": extra["search"],
        "method": extra["motion"],
        "precision": precision,
        "compensation": extra["compensation"],
        "b_residual": extra["b_residual"],
        "whole_frame": extra["whole_frame"],
        "i_max_error": extra["i_max_error"],
    }


def animation_line(target: str, stats: dict) -> str:
    """The line ``volpack compress`` prints for an animation."""
    counts = stats["frame_types"]
    acc = (
        "lossless"
        if stats["lossless"]
        else f"max error {stats['max_error']:g}, PSNR {db(stats['psnr'], stats['max_error'])}"
    )
    return (
        f"{target}: {fmt_bytes(stats['nbytes'])} from {fmt_bytes(stats['raw_nbytes'])}, "
        f"ratio {stats['ratio']:.3f}:1, {acc}; frames I {counts['I']}, P {counts['P']}, "
        f"B {counts['B']} ({stats['scene_cuts']} planned P/B coded as I), "
        f"{fmt_speed(stats['mb_per_s'], stats['seconds'])}"
    )


SHORT = {"forward": "fwd", "backward": "bwd", "bidirectional": "bi", "intra": "intra"}


def frame_table(d: dict) -> str:
    """The per-frame lines of ``volpack info`` for an animation."""
    from ..animation.stream import frame_rows

    s = d.get("summary") or {}
    rows = []
    for r in frame_rows(s, d["header"].get("types") or ""):
        modes = r.get("modes") or {}
        used = ", ".join(f"{SHORT.get(k, k)} {v}" for k, v in modes.items() if v)
        rows.append(
            [
                str(r["t"]),
                r["type"] + ("" if r["type"] == r["planned"] else f" (was {r['planned']})"),
                str(r["nbytes"]),
                str(r["motion_nbytes"]),
                db(r.get("psnr"), r["max_error"]),
                f"{r['max_error']:g}",
                used,
            ]
        )
    head = [
        f"GOP {d['header'].get('gop')}; frame types I {s.get('frame_types', {}).get('I', 0)}, "
        f"P {s.get('frame_types', {}).get('P', 0)}, B {s.get('frame_types', {}).get('B', 0)}; "
        f"{s.get('scene_cuts', 0)} planned P/B coded as I; motion data {s.get('motion_nbytes', 0)} bytes",
        f"block modes: {', '.join(f'{k} {v}' for k, v in (s.get('block_modes') or {}).items())}",
    ]
    return "\n".join(
        head
        + [
            "",
            table(rows, ["t", "type", "bytes", "motion", "PSNR", "max error", "blocks"]),
        ]
    )
