"""``volpack warmup``: compile every kernel once into the on-disk cache."""

from __future__ import annotations

import click

from .options import emit_json, json_option


@click.command(context_settings={"help_option_names": ["-h", "--help"]})
@json_option
def warmup(as_json: bool) -> None:
    """Compile volpack's numba kernels now, so later commands start at once.

    The cache lives under $VOLPACK_CACHE_DIR (default ~/.cache/volpack/jit/<source hash>);
    any change to volpack's sources starts a fresh cache. Set VOLPACK_JIT_CACHE=0 to
    compile in memory only.
    """
    from .. import warmup as w

    report = w.warm()
    if as_json:
        emit_json(report)
    else:
        click.echo(
            f"compiled {report['kernels']} kernel paths in {report['seconds']:.1f} s into {report['cache_dir']}"
        )


COMMANDS = [warmup]
