"""``volpack demo``: the main job on a bundled real volume, offline."""

from __future__ import annotations

import click

from .options import emit_json, json_option, progress_bar, table


@click.command(context_settings={"help_option_names": ["-h", "--help"]})
@click.option(
    "--out",
    "folder",
    default="volpack-demo",
    show_default=True,
    help="Folder for the demo's files.",
)
@click.option(
    "--repeat",
    type=click.IntRange(1, 20),
    default=3,
    show_default=True,
    help="Timing repeats (the best is reported).",
)
@json_option
@click.pass_context
def demo(ctx, folder: str, repeat: int, as_json: bool) -> None:
    """Run every volpack codec on a bundled head MRI and check each round trip.

    The volume is the public-domain 'brainsmall' MRI (84 x 128 x 128, uint8) from
    Stanford VolPack's examples. Files go into --out; the table gives, per stage, the
    compression ratio (raw uint8 bytes / compressed bytes), PSNR or 'lossless', and
    encode and decode speed in MB/s of raw voxels (one thread). The first run also
    compiles volpack's kernels (cached afterwards).
    """
    from .. import demo as d

    with progress_bar(ctx, "demo", unit="stage") as progress:
        report = d.run(folder, repeat=repeat, progress=progress)
    if as_json:
        emit_json(report)
        return
    rows = [
        [
            r["stage"],
            f"{r['ratio']:.3f}",
            "lossless" if r["lossless"] else f"{r['psnr']:.2f} dB",
            f"{r['enc_mb_s']:.1f}",
            f"{r['dec_mb_s']:.1f}",
            str(r["nbytes"]),
        ]
        for r in report["rows"]
    ]
    click.echo(
        f"volpack demo: {report['input']} ({'x'.join(map(str, report['shape']))} {report['dtype']})\n"
    )
    click.echo(table(rows, ["stage", "ratio", "quality", "enc MB/s", "dec MB/s", "bytes"]))
    pv = report["preview"]
    click.echo(f"\nevery round trip checked; files in {report['folder']}/")
    click.echo(f"preview: {pv['file']} (pre-integrated ray casting, {pv['seconds']:.2f} s)")


COMMANDS = [demo]
