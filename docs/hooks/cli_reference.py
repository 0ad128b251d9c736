"""The command-line reference, generated from the CLI itself (``navstack.app:app``).

The typer app is turned into its command tree (``typer.main.get_command``) and every
command, sub-command, argument and option is read off that tree: names, help text, type,
default, bounds and whether it is required.  Only attributes that both click's commands
and typer's own command classes have are used (typer >= 0.16 ships its own copy of
click), so the page follows whichever typer is installed.
"""

from __future__ import annotations

import html
import importlib
import types
import typing
from collections.abc import Iterator
from typing import Any

APP = "navstack.app:app"
PROG = "navstack"


def command_tree(spec: str = APP) -> Any:
    """The command object of the typer app ``module:attribute``."""
    import typer

    module, _, attr = spec.partition(":")
    return typer.main.get_command(getattr(importlib.import_module(module), attr))


def walk(command: Any, path: tuple[str, ...] = ()) -> Iterator[tuple[tuple[str, ...], Any]]:
    """``(path, command)`` for the command and every visible sub-command, depth first,
    sub-commands in the order the help lists them."""
    yield path, command
    for name, sub in (getattr(command, "commands", None) or {}).items():
        if not getattr(sub, "hidden", False):
            yield from walk(sub, (*path, name))


def is_group(command: Any) -> bool:
    return bool(getattr(command, "commands", None))


def param_kind(param: Any) -> str:
    return str(getattr(param, "param_type_name", "option"))


def type_text(param: Any) -> str:
    """``int``, ``float``, ``path``, ``flag``, ...; choices listed."""
    if getattr(param, "is_flag", False):
        return "flag"
    repeat = " (repeatable)" if getattr(param, "multiple", False) else ""
    descriptor = getattr(param, "type_descriptor", None)
    annotation = getattr(descriptor, "annotation", None)
    if annotation is not None:
        while typing.get_args(annotation) and typing.get_origin(annotation) in (
                list, tuple, typing.Union, types.UnionType):
            annotation = next(a for a in typing.get_args(annotation) if a is not type(None))
        name = getattr(annotation, "__name__", str(annotation))
        return {"str": "text", "Path": "path"}.get(name, name) + repeat
    kind = getattr(param, "type", None)
    choices = getattr(kind, "choices", None)
    if choices:
        return " \\| ".join(str(c) for c in choices)
    return str(getattr(kind, "name", "text")) + repeat


def bounds_text(param: Any) -> str:
    lo = getattr(param, "min", None)
    hi = getattr(param, "max", None)
    kind = getattr(param, "type", None)
    lo = lo if lo is not None else getattr(kind, "min", None)
    hi = hi if hi is not None else getattr(kind, "max", None)
    parts = ([f">= {lo}"] if lo is not None else []) + ([f"<= {hi}"] if hi is not None else [])
    return ", ".join(parts)


def default_text(param: Any) -> str:
    if getattr(param, "required", False):
        return "required"
    default = getattr(param, "default", None)
    if default is None or (getattr(param, "is_flag", False) and default is False):
        return ""
    if callable(default):
        return ""
    return f"`{default}`"


def names_text(param: Any) -> str:
    if param_kind(param) == "argument":
        return f"`{str(param.name).upper()}`"
    opts = [*getattr(param, "opts", []), *getattr(param, "secondary_opts", [])]
    return ", ".join(f"`{o}`" for o in opts)


def usage(path: tuple[str, ...], command: Any) -> str:
    pieces = [PROG, *path, "[OPTIONS]"]
    for param in getattr(command, "params", []):
        if param_kind(param) == "argument":
            name = str(param.name).upper()
            pieces.append(name if getattr(param, "required", False) else f"[{name}]")
    if is_group(command):
        pieces.append("COMMAND [ARGS]...")
    return " ".join(pieces)


def cell(text: str) -> str:
    """Help text for a table cell: HTML-escaped, brackets and pipes kept literal."""
    text = html.escape(" ".join(str(text).split()), quote=False)
    return text.replace("|", "&#124;").replace("[", "&#91;").replace("]", "&#93;")


def paragraph(text: str) -> str:
    text = html.escape(text.strip(), quote=False)
    return text.replace("[", "&#91;").replace("]", "&#93;")


def render(spec: str = APP) -> str:
    """The markdown page: one section per command."""
    root = command_tree(spec)
    out = ["# Command line", "",
           f"Generated from the command itself (`{spec}`) each time the guide is built, so "
           "every option below exists under this name.  Every command exits 0 on success, "
           "2 with one `error: ...` line on bad input.", ""]
    for path, command in walk(root):
        title = " ".join((PROG, *path))
        level = "#" * min(2 + max(len(path) - 1, 0), 4)
        out += [f"{level} {title}", "", "```text", usage(path, command), "```", ""]
        help_text = getattr(command, "help", None) or ""
        if help_text:
            out += [paragraph(help_text), ""]
        params = [p for p in getattr(command, "params", []) if not getattr(p, "hidden", False)]
        if params:
            out += ["| argument / option | type | default | allowed | description |",
                    "|---|---|---|---|---|"]
            for p in params:
                out.append(f"| {names_text(p)} | {cell(type_text(p))} | {default_text(p)} | "
                           f"{cell(bounds_text(p))} | {cell(getattr(p, 'help', None) or '')} |")
            out.append("")
        if is_group(command):
            out += ["| command | summary |", "|---|---|"]
            for name, sub in command.commands.items():
                if not getattr(sub, "hidden", False):
                    summary = (getattr(sub, "help", None) or "").strip().split("\n\n")[0]
                    anchor = "-".join((PROG, *path, name)).replace("_", "-")
                    out.append(f"| [`{name}`](#{anchor}) | {cell(summary)} |")
            out.append("")
    return "\n".join(out) + "\n"
