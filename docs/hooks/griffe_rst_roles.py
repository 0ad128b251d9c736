"""Griffe extension: Sphinx cross-reference roles in docstrings become inline code.

navstack's docstrings write ``:class:`~navstack.costmap.layer.Layer``` (Sphinx style);
Markdown would show the role name literally.  This turns every role into inline code of
the name as Sphinx would display it (``~`` keeps only the last component).
"""

from __future__ import annotations

import re
from typing import Any

import griffe

ROLE = re.compile(r":(?:py:)?(?:class|func|meth|mod|data|attr|exc|obj|const|ref):`(~?)([^`]+)`")


def plain(text: str) -> str:
    """``:class:`~a.b.C``` -> ```C```, ``:func:`a.b``` -> ```a.b```."""
    def repl(match: re.Match[str]) -> str:
        name = match.group(2).strip().lstrip(".")
        if match.group(1):
            name = name.rsplit(".", 1)[-1]
        return f"`{name}`"

    return ROLE.sub(repl, text)


class RstRoles(griffe.Extension):
    """Rewrite the roles of every docstring as it is loaded."""

    def on_instance(self, *, obj: griffe.Object, **kwargs: Any) -> None:
        if obj.docstring is not None:
            obj.docstring.value = plain(obj.docstring.value)
