"""Library messages in the shell's words: the Python parameters they name become the
flags of the command that ran (``force=True`` -> ``--force``, ``max_error=2.0`` ->
``--max-error 2.0``). Names that are not the command's parameters are left alone."""

from __future__ import annotations

import re

import click


def flag_words(message: str, command: click.Command | None) -> str:
    if command is None:
        return message
    flags = {
        p.name: max(p.opts, key=len)
        for p in command.params
        if isinstance(p, click.Option) and p.name and p.opts
    }

    def swap(m: re.Match) -> str:
        name, value = m.group(1), m.group(2)
        flag = flags.get(name)
        if flag is None:
            return m.group(0)
        return flag if value == "True" else f"{flag} {value}"

    return re.sub(r"\b([a-z][a-z0-9_]*)=([^\s,;)]+)", swap, message)


def subcommand(ctx: click.Context) -> click.Command | None:
    group = ctx.command
    name = ctx.invoked_subcommand
    if name is None or not isinstance(group, click.Group):
        return None
    return group.get_command(ctx, name)
