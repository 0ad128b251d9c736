"""Plugin registries: names -> plugins, with Nav2 plugin strings as aliases, loaded lazily.

A registry refuses duplicate names and aliases so two plugins can never silently shadow
each other; a lookup of an unknown name lists the known names with a suggestion.

Lazy loading.  A registry may carry a *built-in table* ``{name: module}``: looking up a
name the table knows imports that module, whose decorator then registers the plugin.
So importing a server never imports every planner, and ``navstack --help`` imports
none.  The table only says where to look; the decorator in the module is the one place
a plugin's names are written (``tests/core/test_plugins.py`` checks the two agree).

:class:`ClassRegistry` (registries of plugin classes implementing one interface) also
resolves, in this order after its registered names and its table:

1. ``"package.module:ClassName"`` -- imports the module and takes the class, which must
   implement the registry's interface (decorated or not);
2. the modules named by the ``navstack.plugins`` entry points of installed
   distributions (pluginlib's ``<export>`` equivalent), imported once, on the first
   name no registry knows.
"""

from __future__ import annotations

import contextlib
import functools
import importlib
from collections.abc import Callable, Iterable, Iterator, Mapping
from importlib import metadata
from typing import Any, Generic, TypeVar, cast

from navstack.core.errors import DuplicatePluginError, PluginError, UnknownNameError

T = TypeVar("T")
P = TypeVar("P")

ENTRY_POINT_GROUP = "navstack.plugins"
"""Entry-point group whose modules are imported to find third-party plugins."""


def nav2_spellings(spec: str) -> tuple[str, ...]:
    """Both spellings of a Nav2 plugin type: ``("pkg::Class", "pkg/Class")``.

    ``spec`` is either spelling (Nav2 accepts ``pkg::Class`` and the ROS 1 style
    ``pkg/Class`` alike).  A nested C++ name (``mppi::critics::GoalCritic``) has only
    its ``::`` spelling.
    """
    slash = "::" not in spec
    parts = spec.split("/") if slash else spec.split("::")
    if (len(parts) < 2 or (slash and len(parts) > 2) or not all(parts)
            or any("/" in p or ":" in p for p in parts)):
        raise PluginError(f"Nav2 plugin type '{spec}' must look like 'package::Class' or "
                          f"'package/Class'")
    if len(parts) > 2:
        return ("::".join(parts),)
    return f"{parts[0]}::{parts[1]}", f"{parts[0]}/{parts[1]}"


def builtin_table(modules: Mapping[str, tuple[str, ...]]) -> dict[str, str]:
    """``{module: (names...)}`` -> ``{name: module}`` (each name listed once)."""
    table: dict[str, str] = {}
    for module, names in modules.items():
        for name in names:
            if name in table:
                raise PluginError(f"built-in plugin name '{name}' listed for {table[name]} "
                                 f"and {module}")
            table[name] = module
    return table


def _table_key(name: str) -> str:
    """The built-in table's spelling of ``name`` (``pkg/Class`` -> ``pkg::Class``)."""
    if "::" not in name and name.count("/") == 1:
        return name.replace("/", "::")
    return name


class PluginRegistry(Generic[T]):
    """A named collection of plugins of one kind (``"controller"``, ...).

    ``builtins`` maps names (navstack names and ``pkg::Class`` Nav2 types) to the module
    that registers them, imported on first lookup.
    """

    def __init__(self, kind: str, builtins: Mapping[str, str] | None = None) -> None:
        self.kind = kind
        self._entries: dict[str, T] = {}
        self._aliases: dict[str, str] = {}
        self._builtins: dict[str, str] = {_table_key(k): v for k, v in (builtins or {}).items()}

    # --- registration ---------------------------------------------------------------------
    def register(self, name: str, entry: T, aliases: Iterable[str] = ()) -> T:
        """Register ``entry`` under ``name`` and its ``aliases`` (e.g. Nav2 plugin strings)."""
        aliases = tuple(dict.fromkeys(aliases))
        module = getattr(entry, "__module__", None)
        for key in (name, *aliases):
            if key in self._entries or key in self._aliases:
                raise DuplicatePluginError(
                    f"{self.kind} plugin '{key}' is already registered; pick another name")
            owner = self._builtins.get(_table_key(key))
            if owner is not None and owner != module:
                raise DuplicatePluginError(
                    f"{self.kind} plugin '{key}' is reserved for the built-in plugin in "
                    f"{owner}; pick another name")
        self._entries[name] = entry
        for alias in aliases:
            self._aliases[alias] = name
        return entry

    def decorator(self, name: str, aliases: Iterable[str] = ()) -> Callable[[T], T]:
        """Class decorator form of :meth:`register`."""

        def wrap(entry: T) -> T:
            return self.register(name, entry, aliases)

        return wrap

    def plugin(self, name: str, nav2: str | Iterable[str] = (),
               aliases: Iterable[str] = ()) -> Callable[[T], T]:
        """Class decorator: register under ``name``, both spellings of every Nav2 type in
        ``nav2`` (``"pkg::Class"`` or ``"pkg/Class"``) and any further ``aliases``."""
        specs = (nav2,) if isinstance(nav2, str) else tuple(nav2)
        spelled = [s for spec in specs for s in nav2_spellings(spec)]
        return self.decorator(name, (*spelled, *aliases))

    # --- lookup -------------------------------------------------------------------------
    def _registered(self, name: str) -> str | None:
        if name in self._entries:
            return name
        return self._aliases.get(name)

    def _load_builtin(self, name: str) -> str | None:
        module = self._builtins.get(_table_key(name))
        if module is None:
            return None
        importlib.import_module(module)
        found = self._registered(name)
        if found is None:
            raise PluginError(f"built-in {self.kind} plugin '{name}' should be registered by "
                              f"{module}, but importing it did not register it")
        return found

    def _resolve_extra(self, name: str) -> str | None:
        """Hook for subclasses: find ``name`` beyond the registered names and the table."""
        return None

    def canonical(self, name: str) -> str:
        """The registered name for ``name`` or one of its aliases (importing lazily)."""
        found = self._registered(name) or self._load_builtin(name) or self._resolve_extra(name)
        if found is None:
            raise UnknownNameError(f"{self.kind} plugin", name, self.names())
        return found

    def get(self, name: str) -> T:
        """The entry registered as ``name`` (or an alias of it)."""
        return self._entries[self.canonical(name)]

    __getitem__ = get

    def names(self) -> list[str]:
        """Registered navstack names plus the built-in ones not imported yet."""
        table = (k for k in self._builtins if "::" not in k and ":" not in k)
        return sorted({*self._entries, *table})

    def all_names(self) -> list[str]:
        """Registered names, their aliases and the built-in table's (for suggestions)."""
        table: set[str] = set()
        for key in self._builtins:
            table.add(key)
            if "::" in key:
                table.add(key.replace("::", "/"))
        return sorted({*self._entries, *self._aliases, *table})

    def aliases_of(self, name: str) -> list[str]:
        """Every alias registered for the plugin called ``name`` (or one of its aliases)."""
        canonical = self.canonical(name)
        return sorted(a for a, n in self._aliases.items() if n == canonical)

    def snapshot(self) -> tuple[dict[str, T], dict[str, str]]:
        """The registrations as they are now (for :func:`scoped`)."""
        return dict(self._entries), dict(self._aliases)

    def restore(self, state: tuple[dict[str, T], dict[str, str]]) -> None:
        """Put back the registrations of a :meth:`snapshot`."""
        self._entries, self._aliases = dict(state[0]), dict(state[1])

    def __contains__(self, name: object) -> bool:
        if not isinstance(name, str):
            return False
        try:
            self.canonical(name)
        except UnknownNameError:
            return False
        return True

    def __len__(self) -> int:
        return len(self._entries)


class ClassRegistry(PluginRegistry[type[P]]):
    """A registry of classes implementing ``interface``.

    Besides registered names it resolves ``"module.path:ClassName"`` strings and the
    modules of ``navstack.plugins`` entry points (see the module docstring).
    """

    def __init__(self, kind: str, interface: type,
                 builtins: Mapping[str, str] | None = None) -> None:
        """``interface`` is the class every entry must subclass (``P`` itself; typed
        ``type`` because mypy refuses abstract classes where ``type[P]`` is expected)."""
        super().__init__(kind, builtins)
        self.interface = interface

    def register(self, name: str, entry: type[P], aliases: Iterable[str] = ()) -> type[P]:
        if not (isinstance(entry, type) and issubclass(entry, self.interface)):
            raise PluginError(
                f"{self.kind} plugin '{name}': {entry!r} does not implement "
                f"{self.interface.__module__}.{self.interface.__qualname__}; subclass it")
        return super().register(name, entry, aliases)

    def _resolve_extra(self, name: str) -> str | None:
        if ":" in name and "::" not in name:
            return self._from_module_path(name)
        if load_entry_points():
            return self._registered(name) or self._load_builtin(name)
        return None

    def _from_module_path(self, name: str) -> str:
        module_name, _, attr = name.partition(":")
        try:
            module = importlib.import_module(module_name)
        except ModuleNotFoundError as exc:
            if exc.name is not None and module_name.startswith(exc.name):
                raise PluginError(f"{self.kind} plugin '{name}': no module named "
                                  f"'{module_name}'; is its package installed or on "
                                  f"sys.path?") from None
            raise PluginError(f"importing {module_name} for {self.kind} plugin '{name}' "
                              f"failed: {exc}") from exc
        obj = getattr(module, attr, None)
        if obj is None:
            raise PluginError(f"{self.kind} plugin '{name}': module {module_name} has no "
                              f"attribute '{attr}'")
        if not (isinstance(obj, type) and issubclass(obj, self.interface)):
            raise PluginError(
                f"{self.kind} plugin '{name}' is not a {self.interface.__qualname__}: "
                f"subclass {self.interface.__module__}.{self.interface.__qualname__}")
        for registered, entry in self._entries.items():
            if entry is obj:
                return registered
        self.register(name, cast("type[P]", obj))
        return name


@contextlib.contextmanager
def scoped(*registries: PluginRegistry[Any]) -> Iterator[None]:
    """Registrations made inside the ``with`` block are removed at its end (tests that
    register plugins leave the process-wide registries as they found them)."""
    states = [(r, r.snapshot()) for r in registries]
    try:
        yield
    finally:
        for registry, state in states:
            registry.restore(state)


@functools.cache
def load_entry_points() -> int:
    """Import the modules of every ``navstack.plugins`` entry point, once per process.

    Their decorators register their plugins.  Returns how many entry points were loaded.
    A broken entry point is a :class:`PluginError` naming it and its distribution.
    """
    count = 0
    for ep in metadata.entry_points(group=ENTRY_POINT_GROUP):
        try:
            ep.load()
        except Exception as exc:
            dist = ep.dist.name if ep.dist is not None else "an unknown distribution"
            raise PluginError(f"navstack plugin entry point '{ep.name} = {ep.value}' of "
                              f"{dist} failed to load: {exc}") from exc
        count += 1
    return count
