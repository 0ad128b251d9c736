"""The parameter reference, generated from the pydantic parameter models at build time.

Every subclass of :class:`navstack.core.params.Params` defined in the navstack package is
found by importing every module of the package and walking ``Params.__subclasses__()``,
so a model that moves or is renamed is picked up by the next build.  For each model the
page gives, per key: the key as written in a parameter file (the field's alias if it has
one), its type, default, unit, allowed range, whether it is a Nav2 / slam_toolbox /
robot_localization name, and the note found next to the field in the source.

Units are taken where the source states them: ``[m/s]`` in a field's ``description``,
its attribute docstring or its comment, or ````key`` [unit]`` in the docstring of the
model (or a model it inherits from).  Plugin type strings (``nav2_costmap_2d::...``)
come from the plugin registries.
"""

from __future__ import annotations

import ast
import functools
import importlib
import inspect
import io
import pkgutil
import re
import tokenize
import types
import typing
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Any

import annotated_types
from pydantic import BaseModel
from pydantic.fields import FieldInfo
from pydantic_core import PydanticUndefined

PACKAGE = "navstack"
#: a model whose docstring's first sentence names one of these mirrors that ROS package's
#: parameters (its keys are the package's parameter names) ...
ROS_NAMES = re.compile(r"nav2|Nav2|dwb_|slam_toolbox|robot_localization|amcl|navsat_transform"
                       r"|_filter_node|Costmap2DROS|foxglove_bridge|``\w+Critic``")
#: ... unless the sentence says it has none
NOT_ROS = re.compile(r"navstack extension|navstack's own|no Nav2 counterpart|navstack's")
#: a unit in brackets: ``[m/s]``, ``[rad]``, ``[s^2/m^2]`` (not ``[x, y, yaw]``)
UNIT = r"\[([A-Za-z%°/^*0-9.-][A-Za-z%°/^*0-9. -]{0,14})\]"
UNIT_IN_TEXT = re.compile(UNIT)
#: a comment that only separates groups of fields (``# --- Karto matcher ---``)
SEPARATOR = re.compile(r"^-+ .* -+$")
#: a short comment without a colon labels the fields below it (``# navstack additions``)
LABEL = re.compile(r"^[^:]{1,50}$")


@dataclass
class Key:
    """One documented key of a parameter model."""

    name: str
    type: str
    default: str
    unit: str
    allowed: str
    ros_name: bool
    note: str


@dataclass
class Model:
    """One parameter model and its keys."""

    cls: type
    keys: list[Key] = field(default_factory=list)
    plugin_types: list[str] = field(default_factory=list)

    @property
    def anchor(self) -> str:
        return f"{self.cls.__module__}.{self.cls.__qualname__}"

    @property
    def package(self) -> str:
        """Top-level subpackage (``costmap``, ``control``, ...): one page each."""
        parts = self.cls.__module__.split(".")
        return parts[1] if len(parts) > 1 else parts[0]


@functools.cache
def import_all(package: str = PACKAGE) -> list[str]:
    """Import every module of ``package`` (so every model is defined); their names.

    A module that fails to import fails the build: a reference that silently left out
    a module's parameters would be stale.
    """
    root = importlib.import_module(package)
    names = [package]
    for info in pkgutil.walk_packages(root.__path__, f"{package}."):
        importlib.import_module(info.name)
        names.append(info.name)
    return names


def params_models(package: str = PACKAGE) -> list[type]:
    """Every ``Params`` subclass defined in ``package``, sorted by module and name."""
    import_all(package)
    from navstack.core.params import Params

    found: set[type] = set()
    stack: list[type] = [Params]
    while stack:
        for sub in stack.pop().__subclasses__():
            if sub not in found:
                found.add(sub)
                stack.append(sub)
    return sorted((c for c in found if c.__module__.startswith(f"{package}.")),
                  key=lambda c: (c.__module__, c.__qualname__))


def yaml_key(name: str, info: FieldInfo) -> str:
    """The key as written in a parameter file (the alias if the field has one)."""
    return info.alias or name


# --- source notes: comments and attribute docstrings next to a field -----------------

def _own_doc(cls: type) -> str:
    doc = cls.__dict__.get("__doc__")
    return inspect.cleandoc(doc) if isinstance(doc, str) else ""


@dataclass(frozen=True)
class _SourceFile:
    """A source file read once: its lines, its comments by line number and its classes by
    qualified name.  (``inspect.getsource`` re-parses the whole module for every class
    it is asked for, which made the reference the slowest part of the docs build.)"""

    lines: list[str]
    comments: dict[int, str]
    classes: dict[str, ast.ClassDef]


@functools.cache
def _source_file(filename: str) -> _SourceFile:
    with tokenize.open(filename) as f:
        text = f.read()
    comments = {tok.start[0]: tok.string.lstrip("#").strip()
                for tok in tokenize.generate_tokens(io.StringIO(text).readline)
                if tok.type == tokenize.COMMENT}
    classes: dict[str, ast.ClassDef] = {}

    def visit(node: ast.AST, prefix: str) -> None:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.ClassDef):
                classes[prefix + child.name] = child
                visit(child, f"{prefix}{child.name}.")
            elif isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef)):
                visit(child, f"{prefix}{child.name}.<locals>.")

    visit(ast.parse(text, filename), "")
    return _SourceFile(text.splitlines(), comments, classes)


def _class_node(cls: type) -> tuple[_SourceFile, ast.ClassDef] | None:
    try:
        filename = inspect.getsourcefile(cls)
    except TypeError:
        return None
    if filename is None:
        return None
    src = _source_file(filename)
    node = src.classes.get(cls.__qualname__)
    return (src, node) if node is not None else None


def field_notes(cls: type) -> dict[str, str]:
    """Per field defined in ``cls`` itself: its attribute docstring and comments."""
    found = _class_node(cls)
    if found is None:
        return {}
    src, node = found
    lines, comments, body = src.lines, src.comments, node.body
    notes: dict[str, str] = {}
    label = ""  # a group label comment (``# navstack additions``) applies until a blank line
    for i, stmt in enumerate(body):
        if not (isinstance(stmt, ast.AnnAssign) and isinstance(stmt.target, ast.Name)):
            continue
        parts: list[str] = []
        row = stmt.lineno - 1
        above: list[str] = []
        while row >= 1 and lines[row - 1].strip().startswith("#"):
            text = comments.get(row, "")
            if SEPARATOR.match(text):
                break
            above.insert(0, text)
            row -= 1
        if row >= 1 and not lines[row - 1].strip():
            label = ""
        if above:
            text = " ".join(above)
            label = text if LABEL.match(text) else ""
            parts.append(text)
        elif label:
            parts.append(label)
        end = stmt.end_lineno or stmt.lineno
        parts += [comments[r] for r in range(stmt.lineno, end + 1) if r in comments
                  and not lines[r - 1].strip().startswith("#")]
        nxt = body[i + 1] if i + 1 < len(body) else None
        if (isinstance(nxt, ast.Expr) and isinstance(nxt.value, ast.Constant)
                and isinstance(nxt.value.value, str)):
            parts.append(inspect.cleandoc(nxt.value.value))
        notes[stmt.target.id] = " ".join(p for p in parts if p)
    return notes


def summary(cls: type) -> str:
    """The first sentence of the model's own docstring."""
    first = _own_doc(cls).split("\n\n", 1)[0]
    return " ".join(re.split(r"(?<=\.)\s", first, maxsplit=1)[0].split())


def ros_mirrors(models: list[type], registered: set[type]) -> set[type]:
    """The models whose keys are a ROS package's parameter names: registered plugins and
    models whose first docstring sentence names the package (:data:`ROS_NAMES`); then,
    until nothing changes, models extending one, bases all of whose subclasses are one,
    and models that are a field's type in one (``AmclParams.initial_pose``)."""
    own = {m for m in models if m in registered
           or (ROS_NAMES.search(summary(m)) and not NOT_ROS.search(summary(m)))}
    mirrors = set(own)
    changed = True
    while changed:
        changed = False
        for m in models:
            if m in mirrors or NOT_ROS.search(summary(m)):
                continue
            subs = [s for s in models if m in s.__bases__]
            nested = [o for o in mirrors for f in o.model_fields.values()
                      if m in (f.annotation, *typing.get_args(f.annotation))]
            if (any(b in mirrors for b in m.__bases__) or nested
                    or (subs and all(s in mirrors for s in subs))):
                mirrors.add(m)
                changed = True
    return mirrors


def docstring_units(cls: type) -> dict[str, str]:
    """````key`` [unit]`` statements in the docstrings of ``cls`` and its bases."""
    units: dict[str, str] = {}
    for klass in reversed(cls.__mro__):
        for key, unit in re.findall(r"``(\w+)``\s*" + UNIT, _own_doc(klass)):
            units[key] = unit
    return units


# --- rendering of types, defaults and ranges ------------------------------------------

def type_name(annotation: Any) -> str:
    """A short readable name for a field's annotation."""
    origin = typing.get_origin(annotation)
    args = typing.get_args(annotation)
    if origin is typing.Literal:
        return " \\| ".join(repr(a) for a in args)
    if origin in (typing.Union, types.UnionType):
        return " \\| ".join(type_name(a) for a in args)
    if origin is typing.Annotated:
        return type_name(args[0])
    if origin is not None:
        name = getattr(origin, "__name__", str(origin))
        inner = ", ".join("..." if a is Ellipsis else type_name(a) for a in args)
        return f"{name}[{inner}]" if args else name
    if annotation is type(None):
        return "None"
    if isinstance(annotation, type):
        return annotation.__name__
    return str(annotation).replace("typing.", "")


def default_text(info: FieldInfo) -> str:
    if info.default_factory is not None:
        value = info.default_factory()  # type: ignore[call-arg]
    elif info.default is PydanticUndefined:
        return "required"
    else:
        value = info.default
    if isinstance(value, BaseModel):
        return f"defaults of {type(value).__name__}"
    text = repr(value)
    return text if len(text) <= 80 else text[:77] + "..."


def allowed_text(info: FieldInfo) -> str:
    bounds = []
    for meta in info.metadata:
        for attr, sign in (("ge", ">="), ("gt", ">"), ("le", "<="), ("lt", "<"),
                           ("min_length", "length >="), ("max_length", "length <=")):
            value = getattr(meta, attr, None)
            if value is not None and isinstance(meta, annotated_types.BaseMetadata):
                bounds.append(f"{sign} {value:g}" if isinstance(value, float)
                              else f"{sign} {value}")
    return ", ".join(bounds)


# --- plugin registries ------------------------------------------------------------------

def _params_model_of(plugin: type) -> type | None:
    """The params model a plugin class declares: a class attribute holding a ``Params``
    subclass, else the ``Params`` annotation of its constructor's first parameter."""
    from navstack.core.params import Params

    for klass in plugin.__mro__:
        for value in vars(klass).values():
            if isinstance(value, type) and issubclass(value, Params) and value is not Params:
                return value
    try:
        hints = typing.get_type_hints(plugin.__init__)
    except Exception:  # unresolvable annotations: no model to report
        return None
    for name, hint in hints.items():
        for candidate in (hint, *typing.get_args(hint)):
            if (name != "return" and isinstance(candidate, type)
                    and issubclass(candidate, Params)):
                return candidate
    return None


def _resolve(entry: Any) -> type | None:
    if isinstance(entry, str) and ":" in entry:
        module, _, attr = entry.partition(":")
        entry = getattr(importlib.import_module(module), attr)
    return entry if isinstance(entry, type) else None


def registries(modules: list[str]) -> list[Any]:
    """Every plugin registry defined in ``modules``: an object with ``all_names()`` and
    ``get(name)`` (``navstack.core.registry.PluginRegistry`` and anything shaped like it)."""
    found: list[Any] = []
    seen: set[int] = set()
    for module_name in modules:
        for obj in vars(importlib.import_module(module_name)).values():
            if id(obj) in seen or isinstance(obj, type | dict):
                continue
            if callable(getattr(obj, "all_names", None)) and callable(getattr(obj, "get", None)):
                seen.add(id(obj))
                found.append(obj)
    return found


def plugin_table() -> str:
    """Markdown table: plugin kind, the Nav2 type strings and navstack names that load a
    class, and the class (registries holding the same class are merged)."""
    merged: dict[tuple[str, str], set[str]] = {}
    for registry in registries(import_all()):
        kind = str(getattr(registry, "kind", type(registry).__name__))
        for name in registry.all_names():
            entry = registry.get(name)
            target = entry if isinstance(entry, str) else (
                f"{getattr(entry, '__module__', '')}:{getattr(entry, '__qualname__', entry)}")
            merged.setdefault((kind, target), set()).add(name)
    lines = ["| kind | Nav2 type | navstack name | class |", "|---|---|---|---|"]
    for (kind, target), names in sorted(merged.items()):
        ros = sorted(n for n in names if "::" in n or "/" in n)
        short = sorted(n for n in names if n not in ros)
        lines.append(f"| {kind} | {', '.join(f'`{n}`' for n in ros) or '—'} | "
                     f"{', '.join(f'`{n}`' for n in short)} | `{target}` |")
    return "\n".join(lines) + "\n"


def plugin_types(modules: list[str]) -> dict[type, list[str]]:
    """Params model -> the plugin type strings that load it, from every plugin registry
    (an object with ``all_names()`` and ``get(name)``) defined in the package."""
    out: dict[type, set[str]] = {}
    for registry in registries(modules):
        for name in registry.all_names():
            plugin = _resolve(registry.get(name))
            model = _params_model_of(plugin) if plugin is not None else None
            if model is not None:
                out.setdefault(model, set()).add(name)
    return {m: sorted(names, key=lambda n: ("::" not in n, "/" not in n, n))
            for m, names in out.items()}


# --- assembly -------------------------------------------------------------------------

@functools.cache
def collect() -> list[Model]:
    """Every parameter model with its keys (computed once per process)."""
    modules = import_all()
    registry = plugin_types(modules)
    classes = params_models()
    mirrors = ros_mirrors(classes, set(registry))
    models = []
    for cls in classes:
        units = docstring_units(cls)
        notes: dict[str, str] = {}
        for klass in reversed(cls.__mro__):
            if "model_fields" in vars(klass) or klass is cls:
                notes.update(field_notes(klass))
        ros_model = cls in mirrors
        model = Model(cls, plugin_types=registry.get(cls, []))
        for name, info in cls.model_fields.items():
            note = " ".join(t for t in (info.description or "", notes.get(name, "")) if t)
            unit = units.get(name, "")
            if not unit:
                found = UNIT_IN_TEXT.search(note)
                unit = found.group(1) if found else ""
            nested = [t for t in (info.annotation, *typing.get_args(info.annotation))
                      if isinstance(t, type) and t in classes]
            navstack_only = (bool(re.search(r"\bnavstack\b", note))
                             or any(t not in mirrors for t in nested))
            model.keys.append(Key(
                name=yaml_key(name, info), type=type_name(info.annotation),
                default=default_text(info), unit=unit, allowed=allowed_text(info),
                ros_name=ros_model and not navstack_only, note=note))
        models.append(model)
    return models


def _cell(text: str) -> str:
    """Markdown table-cell text: pipes and brackets escaped, no newlines."""
    text = " ".join(text.split())
    for char, entity in (("|", "&#124;"), ("[", "&#91;"), ("]", "&#93;"), ("<", "&lt;"),
                         (">", "&gt;"), ("*", "&#42;")):
        text = text.replace(char, entity)
    return text


def _code(text: str) -> str:
    return f"`{text}`" if text else ""


def render_model(model: Model) -> Iterator[str]:
    cls = model.cls
    yield f"### {cls.__qualname__} {{#{model.anchor}}}"
    yield ""
    yield f"`{model.anchor}`"
    yield ""
    doc = _own_doc(cls).split("\n\n", 1)[0]
    if doc:
        yield " ".join(doc.split())
        yield ""
    if model.plugin_types:
        yield "Loaded by `plugin:` " + ", ".join(f"`{t}`" for t in model.plugin_types) + "."
        yield ""
    bases = [b for b in cls.__bases__ if b.__name__ != "Params" and hasattr(b, "model_fields")]
    if bases:
        yield "Extends " + ", ".join(
            f"[{b.__qualname__}](#{b.__module__}.{b.__qualname__})" for b in bases) + "."
        yield ""
    if not model.keys:
        yield "No keys."
        yield ""
        return
    yield "| key | type | default | unit | allowed | Nav2 / ROS name | note |"
    yield "|---|---|---|---|---|---|---|"
    for k in model.keys:
        ros = "yes" if k.ros_name else "navstack"
        yield (f"| `{k.name}` | {_cell(k.type)} | {_code(k.default.replace('`', ''))} | "
               f"{_cell(k.unit)} | {_cell(k.allowed)} | {ros} | {_cell(k.note)} |")
    yield ""


def render_page(package: str, models: list[Model]) -> str:
    """The markdown page of one top-level subpackage's models."""
    out = [f"# Parameters: navstack.{package}", "",
           "Generated from the parameter models when the guide is built "
           "([how to read this page](index.md)).", ""]
    module = None
    for model in models:
        if model.cls.__module__ != module:
            module = model.cls.__module__
            out += [f"## {module}", ""]
        out += list(render_model(model))
    return "\n".join(out) + "\n"


def pages() -> dict[str, str]:
    """``{"reference/parameters/<package>.md": markdown}``, one page per subpackage, plus
    the index page listing them."""
    by_package: dict[str, list[Model]] = {}
    for model in collect():
        by_package.setdefault(model.package, []).append(model)
    out = {f"reference/parameters/{pkg}.md": render_page(pkg, models)
           for pkg, models in sorted(by_package.items())}
    total = sum(len(m) for m in by_package.values())
    keys = sum(len(m.keys) for ms in by_package.values() for m in ms)
    rows = "\n".join(f"| [navstack.{pkg}]({pkg}.md) | {len(ms)} | "
                     f"{sum(len(m.keys) for m in ms)} |"
                     for pkg, ms in sorted(by_package.items()))
    out["reference/parameters/index.md"] = INDEX.format(models=total, keys=keys, rows=rows)
    return out


INDEX = """# Parameter reference

Every parameter model of navstack ({models} models, {keys} keys), generated from the
models themselves each time the guide is built, so a renamed or added parameter shows
up here at once (and the build fails rather than list a key that no longer exists).

Each model is a frozen pydantic model (`navstack.core.params.Params`): an unknown key, a
value of the wrong type or out of range is an error naming the file, the key path and the
closest known key.

Columns:

- **key**: the key as written in the YAML file (`controller_server: ros__parameters:
  FollowPath: max_vel_x: ...`); for Nav2, slam_toolbox and robot_localization models
  this is the ROS package's own parameter name.
- **type**, **default**: as the model declares them; `required` has no default.
- **unit**: where the source states one (`[m/s]` next to the field or in the model's
  docstring); SI units and radians throughout otherwise.
- **allowed**: the bounds the model enforces.
- **Nav2 / ROS name**: `yes` when the key is the ROS package's parameter of the same name,
  `navstack` when the model or the field is navstack's own (no ROS counterpart).
- **note**: the comment or docstring next to the field in the source.

A model registered as a plugin lists the `plugin:` type strings that load it
(`nav2_costmap_2d::InflationLayer`, ...).

| package | models | keys |
|---|---|---|
{rows}
"""
