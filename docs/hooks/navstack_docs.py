"""MkDocs hook: the generated reference pages and the navigation of the user guide.

At every build this hook generates, in memory (nothing is written to ``docs/``):

* ``reference/parameters/*.md`` from the pydantic parameter models
  (:mod:`params_reference`),
* ``reference/cli.md`` from the ``navstack`` command itself (:mod:`cli_reference`),
* ``reference/api/*.md`` (mkdocstrings directives, one per module) and
  ``reference/benchmarks.md`` (:mod:`api_reference`),

fills the plugin table of ``nav2.md`` from the plugin registries, and builds the
navigation: the guide pages, the generated reference, then every other
Markdown file directly in ``docs/`` as a design note, so a new note appears without an
edit here.
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))

import api_reference
import cli_reference
import params_reference
from mkdocs.structure.files import File, Files

GUIDE: list[Any] = [
    {"Home": "index.md"},
    {"Getting started": "getting-started.md"},
    {"Tutorials": [
        {"Office robot (diff-drive)": "tutorials/office.md"},
        {"Campus golf cart": "tutorials/golf-cart.md"},
        {"TurtleBot package retrieval": "tutorials/turtlebot.md"},
        {"Planetary rover": "tutorials/rover.md"},
    ]},
    {"Coming from Nav2": "nav2.md"},
]
"""Hand-written pages, in order; every other ``docs/*.md`` is a design note."""

_generated: dict[str, str] = {}
PLUGIN_TABLE = "<!-- navstack:plugin-table -->"
"""Where ``nav2.md`` wants the table of plugin type strings."""


def generated_pages() -> dict[str, str]:
    """Every generated page, ``{path under docs/: markdown}``."""
    pages = {**params_reference.pages(), **api_reference.api_pages(),
             "reference/cli.md": cli_reference.render(),
             "reference/benchmarks.md": api_reference.benchmarks_page()}
    return dict(sorted(pages.items()))


def _guide_paths(items: list[Any]) -> set[str]:
    out: set[str] = set()
    for item in items:
        for value in item.values():
            out |= _guide_paths(value) if isinstance(value, list) else {value}
    return out


def on_config(config: Any) -> Any:
    _generated.clear()
    _generated.update(generated_pages())
    docs = Path(config["docs_dir"])
    notes = sorted(p.name for p in docs.glob("*.md") if p.name not in _guide_paths(GUIDE))
    notes.sort(key=lambda name: name != "decisions.md")
    params = [p for p in _generated if p.startswith("reference/parameters/")]
    api = [p for p in _generated if p.startswith("reference/api/")]
    index_first = sorted(params, key=lambda p: not p.endswith("index.md"))
    api_first = sorted(api, key=lambda p: not p.endswith("index.md"))
    config["nav"] = [*GUIDE, {"Reference": [
        {"Parameters": index_first},
        {"Command line": "reference/cli.md"},
        {"Benchmarks": "reference/benchmarks.md"},
        {"Python API": api_first},
    ]}, {"Design notes": notes}]
    return config


def on_files(files: Files, config: Any) -> Files:
    for path, content in _generated.items():
        files.append(File.generated(config, path, content=content))
    return files


def on_page_markdown(markdown: str, page: Any, **kwargs: Any) -> str:
    """Fill the generated tables that hand-written pages ask for by a marker."""
    if PLUGIN_TABLE in markdown:
        markdown = markdown.replace(PLUGIN_TABLE, params_reference.plugin_table())
    return markdown
