"""The ``volpack`` command line: a thin layer of click commands over the library.

It lives inside the package (``volpack/cli/``) rather than as a top-level ``cli``
package, which would be installed into site-packages under the bare name ``cli`` and
collide with other projects. Each command group is a small module here; the library is
imported inside the command bodies so that ``volpack --help`` loads neither numpy's
heavier users nor numba.

Exit codes: 0 success, 1 an error the user can act on (a :class:`~volpack.errors.VolpackError`,
``OSError`` or ``MemoryError``: one line ``volpack: error: ...`` naming flags, the traceback
only with ``--debug``), 2 a usage error (click's own), 3 an internal error (any other
exception: a bug, reported as one line, the traceback with ``--debug``), 130 Ctrl-C (one
line ``volpack: interrupted``; outputs are written atomically, so none is left half
written).
"""

from __future__ import annotations

import logging
import os
import sys
import traceback
import warnings

import click

from .. import __version__
from ..errors import EXIT_INTERNAL

EXIT_INTERRUPTED = 130  # 128 + SIGINT, as shells report a command stopped by Ctrl-C

CONTEXT = {"help_option_names": ["-h", "--help"], "max_content_width": 100}

# Command -> the module of this package that defines it (in its COMMANDS). A command's
# module is imported when the command runs or is listed, not the others: importing all
# nine took 15-50 ms of every command (tests/cli/test_cli.py checks this table).
COMMAND_MODULES = {
    "info": "info", "convert": "convert", "compress": "codec", "decompress": "codec",
    "compare": "compare", "batch": "batch", "demo": "demo", "warmup": "jit",
    "render": "render", "play": "play", "walk": "play", "serve": "serve",
}  # fmt: skip


GLOBAL_FLAGS = frozenset({"-q", "--quiet", "-v", "-vv", "-vvv", "--verbose", "--debug"})


def hoist_global_flags(args: list[str]) -> list[str]:
    """``volpack compress a b -q`` as ``volpack -q compress a b``: the group's flags
    (which no command reuses) are taken from anywhere before a ``--``."""
    cut = args.index("--") if "--" in args else len(args)
    head = args[:cut]
    flags = [a for a in head if a in GLOBAL_FLAGS]
    return flags + [a for a in head if a not in GLOBAL_FLAGS] + args[cut:]


class VolpackGroup(click.Group):
    """A click group that reports errors: a one-line message for what the user can fix,
    "internal error, please report" (exit 3) for anything else, which is a bug. Its
    commands load on first use (:data:`COMMAND_MODULES`)."""

    def parse_args(self, ctx: click.Context, args: list[str]) -> list[str]:
        return super().parse_args(ctx, hoist_global_flags(args))

    def list_commands(self, ctx: click.Context) -> list[str]:
        return sorted({*self.commands, *COMMAND_MODULES})

    def get_command(self, ctx: click.Context, name: str):
        if name not in self.commands and name in COMMAND_MODULES:
            import importlib

            module = importlib.import_module(f"{__name__}.{COMMAND_MODULES[name]}")
            for cmd in module.COMMANDS:
                self.add_command(cmd)
        return self.commands.get(name)

    def resolve_command(self, ctx: click.Context, args: list[str]):
        name, cmd, rest = super().resolve_command(ctx, args)
        ctx.meta["volpack.command"] = cmd
        return name, cmd, rest

    def invoke(self, ctx: click.Context):
        try:
            return super().invoke(ctx)
        except (click.exceptions.Exit, click.ClickException, click.Abort):
            raise
        except KeyboardInterrupt:
            click.echo("volpack: interrupted", err=True)
            # what the interrupt cut short may complain as it is collected (zarr's coroutine
            # never awaited, its event loop closed while running): the one line above is all
            # the user is told
            warnings.simplefilter("ignore")
            sys.unraisablehook = lambda unraisable: None
            sys.exit(EXIT_INTERRUPTED)
        except BrokenPipeError:
            sys.exit(1)
        except Exception as e:
            from ..errors import VolpackError
            from .errors import as_flags, flag_map

            debug = bool(ctx.obj and ctx.obj.get("debug"))
            if not isinstance(e, (VolpackError, OSError, MemoryError)):
                if debug:
                    traceback.print_exc()
                line = str(e).splitlines()[0] if str(e) else ""
                msg = f"internal error, please report: {type(e).__name__}: {line}"
                click.echo(f"volpack: {msg}", err=True)
                _json_error(ctx, msg)
                sys.exit(EXIT_INTERNAL)
            if debug:
                raise
            msg = str(e) or type(e).__name__
            if isinstance(e, OSError) and e.filename and e.strerror:
                msg = f"{e.filename}: {e.strerror}"
            elif isinstance(e, VolpackError):
                msg = as_flags(msg, flag_map(self, ctx.meta.get("volpack.command")))
                msg = _naming_the_file(e, msg)
            click.echo(f"volpack: error: {msg}", err=True)
            _json_error(ctx, msg)
            sys.exit(1)


def _naming_the_file(e: Exception, message: str) -> str:
    """A FormatError from reading a named file: that file before the message (one line;
    the library's message is kept), or, for a file of another format, what it is."""
    from ..errors import FormatError

    path = getattr(e, "path", None)
    if not isinstance(e, FormatError) or not path:
        return message
    from ..api import refuse_other_format  # only now: walk's start imports no more

    try:
        refuse_other_format(path)
    except FormatError as other:  # 'found the npy file ...' rather than magic bytes
        return str(other)
    return message if path in message else f"{path}: {message}"


def _json_error(ctx: click.Context, message: str) -> None:
    """With --json, the error on standard output as well: a script reading the JSON
    gets an object with "error" rather than no output at all."""
    if ctx.meta.get("volpack.json"):
        import json

        click.echo(json.dumps({"error": message}))


@click.group(cls=VolpackGroup, context_settings=CONTEXT)
@click.version_option(__version__, "--version", prog_name="volpack")
@click.option("-v", "--verbose", count=True, help="Log what the library does (-vv for more).")
@click.option("-q", "--quiet", is_flag=True, help="No progress bars.")
@click.option("--debug", is_flag=True, help="Show a full traceback on errors.")
@click.pass_context
def main(ctx: click.Context, verbose: int, quiet: bool, debug: bool) -> None:
    """Compress, preprocess and preview volume data.

    \b
    Examples:
      volpack demo                                  run every codec on a bundled MRI
      volpack info head.nii.gz                      shape, dtype, spacing, value range
      volpack convert ct.nrrd ct.npy --crop 10:90,0:256,0:256 --downsample 2
      volpack compress ct.nii.gz ct.vpk             lossless integer wavelet codec
      volpack decompress ct.vpk roi.npy --roi 40:80,100:200,100:200

    Files: .npy, .raw (--shape/--dtype), .nii/.nii.gz, .nrrd/.nhdr, .h5:/dataset,
    .nc/.cdf (netCDF, :VARIABLE), .mrc/.map/.ccp4 (MRC/CCP4 maps), .zarr stores,
    .mha/.mhd (MetaImage), .vti (VTK image data), .inr/.inr.gz, .tif (multi-page) or a
    folder of .tif or greyscale .png slices (a .png: one slice; read), a DICOM folder,
    VolPack .den, InVesalius .inv3 (read), and '-' for standard input/output (npy or vpk
    streams). Run 'volpack COMMAND --help' for more;
    -q, -v and --debug may also follow the command.
    """
    ctx.ensure_object(dict)
    ctx.obj.update(quiet=quiet, debug=debug, verbose=verbose)
    from .notices import install

    install(ctx, quiet)
    level = logging.WARNING - 10 * min(verbose, 2)
    logging.basicConfig(
        level=level, format="volpack: %(levelname)s: %(message)s", stream=sys.stderr
    )


def run() -> None:
    """The ``volpack`` console entry: :func:`main`, then a quick exit.

    Once a command has finished, the interpreter's own shutdown (waiting for threads, the
    atexit handlers, flushing) is done here and its teardown of every module is skipped:
    tearing down numba and llvmlite takes about 0.25 s of CPU, a third of a small decode.
    Exceptions that escape click (none should) still take Python's normal path.
    """
    from . import options

    options.WHOLE_PROCESS = True  # what a command imports may be frozen (imports_without_gc)
    try:
        main()
        code = 0
    except SystemExit as e:
        code = e.code
    if code is not None and not isinstance(code, int):
        print(code, file=sys.stderr)
        code = 1
    if code != EXIT_INTERRUPTED:  # Ctrl-C: no waiting for worker threads to finish their
        _shut_down()  # files (a batch's took minutes); their outputs are never named
    else:
        _release_process_locks()
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):  # a closed pipe (volpack info | head): nothing to keep
            code = code or 1
    os._exit(code or 0)


def _release_process_locks() -> None:
    """After Ctrl-C, the locks of an abandoned process pool's queues released as a normal
    exit would: without it, multiprocessing's resource tracker (a process of its own,
    sharing stderr) warns of leaked semaphores after 'volpack: interrupted'. Only the
    finalizers a normal exit runs first are run (priority 0 and above: queues closed,
    locks unlinked), not the later ones that join the queues' feeder threads."""
    util = sys.modules.get("multiprocessing.util")
    if util is not None:
        util._run_finalizers(0)


def _shut_down() -> None:
    """The interpreter's own shutdown: join non-daemon threads, run the atexit handlers."""
    import atexit
    import threading

    shutdown = getattr(threading, "_shutdown", None)  # joins non-daemon threads
    if shutdown is not None:
        shutdown()
    atexit._run_exitfuncs()
