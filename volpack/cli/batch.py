"""``volpack batch``: many volumes to ``.vpk`` files, here or on a Dask cluster; and the
shared runner behind ``volpack decompress --batch``."""

from __future__ import annotations

import contextlib
import os
import sys
import time
from collections.abc import Iterator

import click

from .options import (
    codec_options,
    emit_json,
    fmt_bytes,
    json_option,
    option,
    options,
    parse_brick,
    raw_options,
)


@contextlib.contextmanager
def files_bar(ctx: click.Context, desc: str) -> Iterator:
    """A ``progress(done, total, raw_bytes)`` callback drawing files and MB/s (terminal only)."""
    root = ctx.find_root()
    quiet = bool(root.obj.get("quiet")) if root.obj else False
    if quiet or not sys.stderr.isatty():
        yield None
        return
    from tqdm import tqdm

    bar = tqdm(desc=desc, unit="file", file=sys.stderr, leave=False, dynamic_ncols=True)
    t0 = time.perf_counter()

    def update(done: int, total: int, nbytes: int) -> None:
        bar.total = total
        bar.n = done
        bar.set_postfix_str(f"{nbytes / 1e6 / max(time.perf_counter() - t0, 1e-9):.1f} MB/s")
        bar.refresh()

    try:
        yield update
    finally:
        bar.close()


def run_batch(
    ctx: click.Context,
    tasks,
    out_dir: str,
    desc: str,
    workers: int,
    force: bool,
    as_json: bool,
    *,
    scheduler: str | None = None,
    resume: bool = False,
    fail_fast: bool = False,
    report_path: str | None = None,
) -> None:
    """Run planned tasks with a progress bar; report; exit 1 if any file failed."""
    from .. import batch
    from ..format.atomic import check_output

    if report_path:  # refuse before the run, not after it: a resumed run may replace it
        check_output(report_path, force=force or resume)
    with files_bar(ctx, desc) as progress:
        report = batch.run(
            tasks,
            workers=workers,
            scheduler=scheduler,
            resume=resume,
            journal=os.path.join(out_dir, batch.JOURNAL_NAME),
            fail_fast=fail_fast,
            force=force,
            progress=progress,
        )
    if report_path:
        batch.write_report(report, report_path)
    t = report["totals"]
    if as_json:
        emit_json(report)
    for f in report["files"]:
        if f["status"] == "failed":
            click.echo(f"volpack: failed: {f['input']}: {f['error']}", err=True)
    sizes = f"{fmt_bytes(t['raw_nbytes'])} -> {fmt_bytes(t['nbytes'])}"
    if desc == "decompress":
        sizes = f"{fmt_bytes(t['nbytes'])} -> {fmt_bytes(t['raw_nbytes'])}"
    ratio = f"ratio {t['ratio']:.2f}:1, " if t["ratio"] else ""
    summary = (
        f"{out_dir}: {t['ok']} ok, {t['failed']} failed, {t['skipped']} skipped"
        + (f", {t['cancelled']} cancelled" if t["cancelled"] else "")
        + f" of {t['files']} files; {sizes}, "
        f"{ratio}{t['seconds']:.1f} s, {t['files_per_s']:.2f} files/s, {t['mb_per_s']:.1f} MB/s"
    )
    if t["failed"] or t["cancelled"]:
        click.echo(f"volpack: error: {summary}", err=True)
        sys.exit(1)
    if not as_json:
        click.echo(summary, err=True)


@click.command(context_settings={"help_option_names": ["-h", "--help"]})
@click.argument("inputs", nargs=-1, required=True)
@click.argument("out_dir")
@codec_options
@options(
    option("-j --workers", "Files converted at once (0 = every core); with --scheduler local, "
           "Dask workers.", (0, None), 1),
    option("--threads", "Threads for the bricks of each file (0 = every core).", (0, None), 1),
    option("--scheduler", "Run on Dask: a scheduler address (tcp://head:8786) or 'local' for a "
           "LocalCluster.", metavar="ADDRESS"),
    option("--resume", "Skip files the journal shows done and intact.", bool),
    option("--verify", "decode: decode each output and compare with its input; checksum: "
           "check its CRCs.", ["decode", "checksum"], "decode"),
    option("--fail-fast", "Stop starting files after the first failure.", bool),
    option("--report report_path", "Write the JSON report here.", metavar="FILE"),
    option("-f --force", "Replace existing outputs.", bool),
)  # fmt: skip
@raw_options
@json_option
@click.pass_context
def batch(
    ctx,
    inputs,
    out_dir,
    workers,
    threads,
    scheduler,
    resume,
    verify,
    fail_fast,
    report_path,
    force,
    read_options,
    as_json,
    **codec,
) -> None:
    """Compress every volume of INPUTS into OUT_DIR, one .vpk per input.

    INPUTS are globs ('**' recurses; quote them), folders (every readable volume below),
    files, or a .csv/.json manifest (column 'input', optional 'output' and per-file
    options such as max_error or coder; a relative 'output' is inside OUT_DIR and may not
    leave OUT_DIR with '..', an absolute one is taken as it is). OUT_DIR mirrors the
    inputs' tree. Every output
    is written atomically, verified, and logged in OUT_DIR/.volpack-batch.jsonl, so
    --resume redoes only what is missing, changed or damaged. A file that fails is
    reported and the others go on; the exit status is then 1.

    \b
    Examples:
      volpack batch 'scans/**/*.nii.gz' out/ --max-error 0.5 --workers 8
      volpack batch manifest.csv out/ --resume
      volpack batch 'run/*.h5:/T' out/ --scheduler tcp://head:8786
      volpack batch scans/ out/ --report report.json --json
    """
    from .. import batch as vbatch

    opts = {k: v for k, v in codec.items() if v is not None}
    if "brick" in opts:
        opts["brick"] = parse_brick(opts["brick"])
    opts["workers"] = threads
    opts.update(read_options)
    skipped: list[tuple[str, str]] = []
    tasks = vbatch.plan(list(inputs), out_dir, options=opts, verify=verify, skipped=skipped)
    if skipped and not as_json:  # say what was found and left out, and why
        click.echo(
            f"volpack: batch: left out {len(skipped)} file(s) found among the inputs:", err=True
        )
        for path, why in skipped:
            click.echo(f"  {path}: {why}", err=True)
    run_batch(
        ctx, tasks, out_dir, "batch", workers, force, as_json,
        scheduler=scheduler, resume=resume, fail_fast=fail_fast, report_path=report_path,
    )  # fmt: skip


COMMANDS = [batch]
