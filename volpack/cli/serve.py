"""``volpack serve``: keep a volpack process with its kernels loaded, for fast previews."""

from __future__ import annotations

import os
import subprocess
import sys
import time

import click

from .options import emit_json, json_option


def _runner(argv: list[str]) -> None:
    from . import main

    main.main(args=argv, prog_name="volpack", standalone_mode=True)


@click.command(context_settings={"help_option_names": ["-h", "--help"]})
@click.option(
    "--idle",
    type=click.FloatRange(min=0),
    default=1800.0,
    show_default=True,
    help="Exit after this many seconds without a request (0: never).",
)
@click.option(
    "--warm/--no-warm",
    default=True,
    show_default=True,
    help="Load the ray caster's kernels for uint8, int16, uint16 and float32 first.",
)
@click.option(
    "--detach", is_flag=True, help="Start the server in the background and return once it listens."
)
@click.option("--stop", "stop_", is_flag=True, help="Ask this install's server to exit.")
@click.option("--status", is_flag=True, help="Say whether this install's server listens: "
              "exit 0 if it does, 1 if none does.")  # fmt: skip
@json_option
def serve(idle: float, warm: bool, detach: bool, stop_: bool, status: bool, as_json: bool) -> None:
    """Run volpack as a resident server, so that `volpack render`, `info`, `walk` and
    `play` start at once.

    A new process spends about half a second loading numba and its kernels before it
    renders anything. While a server of this install listens, the `volpack` command
    sends those commands to it over a private Unix socket and prints what it answers:
    same files, same bytes, same exit codes. Only code stays loaded; every request
    reads its files afresh. Requests run one at a time. Commands that read standard
    input or write standard output ('-') run in their own process, as does everything
    when VOLPACK_SERVE=0 is set.

    \b
    Examples:
      volpack serve --detach            start it in the background
      volpack render head.nii.gz out/   served while it listens
      volpack serve --status --json     is it listening, and where
      volpack serve --stop              ask it to exit

    The socket lives in $VOLPACK_SERVE_DIR, else $XDG_RUNTIME_DIR/volpack, else
    ~/.cache/volpack/serve; its name carries a stamp of this install (sources, Python,
    VOLPACK_* and NUMBA_* settings), so an edited tree never reaches an old server.
    """
    from .. import serve as sv

    path = sv.socket_path()
    if stop_ or status:
        up = sv.stop(path) if stop_ else sv.listening(path)
        none = f"no server listens on {path} ('volpack serve --detach' starts one)"
        if as_json:
            report = {"socket": str(path), "listening": up and not stop_, "stopped": stop_ and up}
            emit_json(report if up or stop_ else {**report, "error": none})
        elif stop_:
            click.echo(f"stopped the server on {path}" if up else none)
        else:
            click.echo(f"listening on {path}" if up else none)
        if status and not up:  # scripts test the status: `volpack serve --status || ...`
            raise SystemExit(1)
        return
    if detach and sv.listening(path):  # already up: nothing to start
        if as_json:
            emit_json({"socket": str(path), "listening": True, "pid": None})
        else:
            click.echo(f"a server already listens on {path}")
        return
    if detach:
        if not as_json:
            click.echo("volpack serve: starting in the background (loading the kernels; on an "
                       "empty kernel cache they compile first, a few minutes)", err=True)  # fmt: skip
        args = [sys.executable, "-m", "volpack", "serve", "--idle", f"{idle:g}"]
        args += [] if warm else ["--no-warm"]
        child = subprocess.Popen(args, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                         stderr=subprocess.DEVNULL, start_new_session=True)  # fmt: skip
        deadline = time.monotonic() + 600.0  # warming compiles on an empty kernel cache
        while not sv.listening(path):
            if child.poll() is not None:
                raise click.ClickException(
                    f"the server ended at once (exit {child.returncode}); "
                    "'volpack serve' in the foreground says why"
                )
            if time.monotonic() > deadline:
                raise click.ClickException(f"the server did not start listening on {path}")
            time.sleep(0.05)
        if as_json:
            emit_json({"socket": str(path), "listening": True, "pid": child.pid})
        else:
            click.echo(f"listening on {path} (process {child.pid}; 'volpack serve --stop' ends it)")
        return
    say = (
        (lambda line: None)
        if as_json
        else (lambda line: click.echo(f"volpack serve: {line}", err=True))
    )
    try:
        served = sv.serve(_runner, idle=idle, warm=warm, log=say)
    except (KeyboardInterrupt, sv.Terminate):
        say("stopped")
        raise SystemExit(0) from None
    if as_json:
        emit_json({"socket": str(path), "served": served, "pid": os.getpid()})


COMMANDS = [serve]
