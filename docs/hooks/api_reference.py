"""The Python API reference pages (mkdocstrings) and the benchmark suite list.

The modules are listed by walking the package's source tree at build time, so a module
that moves, appears or disappears changes the pages with no edit here.  Each page holds
one ``::: module`` directive per module of a top-level subpackage; mkdocstrings reads the
docstrings statically (griffe), nothing is executed.
"""

from __future__ import annotations

import ast
import importlib
from pathlib import Path

SRC = Path(__file__).resolve().parents[2] / "src"
PACKAGE = "navstack"


def modules(src: Path = SRC, package: str = PACKAGE) -> dict[str, list[str]]:
    """``{subpackage: [module, ...]}`` of every Python module under ``src/package``
    (``__init__`` as the package itself), the top-level modules under ``""``."""
    root = src / package
    out: dict[str, list[str]] = {}
    for path in sorted(root.rglob("*.py")):
        rel = path.relative_to(src).with_suffix("")
        parts = list(rel.parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        if parts[-1] == "__main__":
            continue
        group = parts[1] if len(parts) > 1 and (root / parts[1]).is_dir() else ""
        out.setdefault(group, []).append(".".join(parts))
    return out


def summary(module: str, src: Path = SRC) -> str:
    """The first line of a module's docstring, read without importing it."""
    parts = module.split(".")
    path = src.joinpath(*parts).with_suffix(".py")
    if not path.exists():
        path = src.joinpath(*parts, "__init__.py")
    doc = ast.get_docstring(ast.parse(path.read_text())) or ""
    return doc.strip().split("\n")[0]


def api_pages() -> dict[str, str]:
    """``{"reference/api/<group>.md": markdown}`` plus the index page."""
    groups = modules()
    pages: dict[str, str] = {}
    index = ["# Python API", "",
             "Generated from the docstrings (mkdocstrings) each time the guide is built.  "
             "Algorithm packages (`costmap`, `planning`, `control`, `localization`, "
             "`mapping`, `perception`, `geo`) work on numpy inputs without a running stack; "
             "`NavStack` and `Navigator` (in `interfaces`) run the whole stack.", "",
             "| package | modules | what |", "|---|---|---|"]
    for group, names in sorted(groups.items()):
        slug = group or PACKAGE
        title = f"{PACKAGE}.{group}" if group else PACKAGE
        lines = [f"# {title}", ""]
        for name in names:
            lines += [f"::: {name}", "    options:", "      heading_level: 2", ""]
        pages[f"reference/api/{slug}.md"] = "\n".join(lines)
        what = summary(names[0]) if group else "the package and the `navstack` command"
        index.append(f"| [{title}]({slug}.md) | {len(names)} | {what} |")
    pages["reference/api/index.md"] = "\n".join(index) + "\n"
    return pages


def benchmarks_page() -> str:
    """Every suite ``navstack bench`` runs, from the runner's registry and each suite
    module's docstring."""
    runner = importlib.import_module(f"{PACKAGE}.benchmarks.runner")
    out = ["# Benchmarks", "",
           "Generated from the suite registry (`navstack.benchmarks.runner.SUITE_MODULES`) "
           "each time the guide is built.", "",
           "```bash",
           "navstack bench list                        # the suites below",
           "navstack bench SUITE [--quick] [--json FILE] [--data-dir DIR]",
           "```", "",
           "`--quick` runs a smaller case set (budgets are checked on full runs only); "
           "`--json` writes `{\"suite\", \"machine\", \"metrics\", \"cases\", \"notes\"}`.  "
           "Input data (CARMEN logs, g2o graphs, MovingAI maps) is looked up in `--data-dir`, "
           "then `$NAVSTACK_DATA`, then the data shipped in `navstack/data`, then "
           "`../shared/data`; a missing file is an error that names it and where to get it.",
           ""]
    for name, module in sorted(runner.SUITE_MODULES.items()):
        mod = importlib.import_module(module)
        doc = (mod.__doc__ or "").strip()
        first, _, rest = doc.partition("\n\n")
        out += [f"## {name}", "", f"`{module}`", "", first, ""]
        if rest:
            out += [rest, ""]
    return "\n".join(out) + "\n"
