"""How the command line reports errors: library parameter names become flags.

Library messages name Python parameters (``max_error``, ``codec='zstd'``,
``force=True``) so that they read right from Python. A command-line user typed flags, so
the one-line report names the flag instead: ``name=value`` becomes ``--name value``
(``--name`` alone for ``True``), and a bare ``snake_case`` parameter becomes its flag.
The names come from the options of the command that failed, then of every command;
:data:`FLAGS` holds the few whose flag is not the parameter's name.
"""

from __future__ import annotations

import re

import click

# library parameter -> flag, where the flag is not derived from the parameter's name
FLAGS = {"method": "--motion", "shape": "--shape", "dtype": "--dtype"}

# name=value (value: a quoted string, True or a number; may be empty) or a snake_case name
_NAMED = re.compile(r"\b([a-z][a-z0-9]*(?:_[a-z0-9]+)*)=('[^']*'|True\b|-?[0-9][0-9.e+-]*)?")
_SNAKE = re.compile(r"(?<![\w./\\'\"-])([a-z][a-z0-9]*(?:_[a-z0-9]+)+)\b(?![=(/'\"]|\.\w)")


def _options(command: click.Command | None) -> dict[str, str]:
    out: dict[str, str] = {}
    for p in getattr(command, "params", ()):
        longs = [o for o in p.opts if o.startswith("--")]
        if isinstance(p, click.Option) and longs and p.name:
            out.setdefault(p.name, longs[0])
    return out


def flag_map(group: click.Group, command: click.Command | None) -> dict[str, str]:
    """Parameter name -> flag: the failing command's options first, then every command's."""
    names: dict[str, str] = {}
    stack = [group]
    while stack:
        g = stack.pop()
        for c in (g.get_command(None, n) for n in g.list_commands(None)):  # loads them all
            if isinstance(c, click.Group):
                stack.append(c)
            else:
                for k, v in _options(c).items():
                    names.setdefault(k, v)
    names.update(_options(command))
    names.update(FLAGS)
    return names


def as_flags(message: str, flags: dict[str, str]) -> str:
    """Rewrite the parameter names in a library message as the command line's flags."""

    def named(m: re.Match) -> str:
        flag = flags.get(m.group(1))
        if flag is None:
            return m.group(0)
        value = m.group(2)
        if not value or value == "True":
            return flag
        return f"{flag} {value.strip(chr(39))}"

    def snake(m: re.Match) -> str:
        return flags.get(m.group(1), m.group(0))

    return _SNAKE.sub(snake, _NAMED.sub(named, message))
