"""Plugin registry: names -> factories, with Nav2 plugin strings as aliases.

A registry refuses duplicate names and aliases so two plugins can never silently shadow
each other; a lookup of an unknown name lists the known names with a suggestion.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from typing import Generic, TypeVar

from navstack.core.errors import DuplicatePluginError, UnknownNameError

T = TypeVar("T")


class PluginRegistry(Generic[T]):
    """A named collection of plugin factories of one kind (``"controller"``, ...)."""

    def __init__(self, kind: str) -> None:
        self.kind = kind
        self._entries: dict[str, T] = {}
        self._aliases: dict[str, str] = {}

    def register(self, name: str, entry: T, aliases: Iterable[str] = ()) -> T:
        """Register ``entry`` under ``name`` and its ``aliases`` (e.g. Nav2 plugin strings)."""
        aliases = tuple(aliases)
        for key in (name, *aliases):
            if key in self._entries or key in self._aliases:
                raise DuplicatePluginError(
                    f"{self.kind} plugin '{key}' is already registered; pick another name"
                )
        self._entries[name] = entry
        for alias in aliases:
            self._aliases[alias] = name
        return entry

    def decorator(self, name: str, aliases: Iterable[str] = ()) -> Callable[[T], T]:
        """Class decorator form of :meth:`register`."""

        def wrap(entry: T) -> T:
            return self.register(name, entry, aliases)

        return wrap

    def canonical(self, name: str) -> str:
        """The registered name for ``name`` or one of its aliases."""
        if name in self._entries:
            return name
        if name in self._aliases:
            return self._aliases[name]
        raise UnknownNameError(f"{self.kind} plugin", name, self.names())

    def get(self, name: str) -> T:
        """The entry registered as ``name`` (or an alias of it)."""
        return self._entries[self.canonical(name)]

    def names(self) -> list[str]:
        return sorted(self._entries)

    def all_names(self) -> list[str]:
        """Registered names and their aliases (for suggestions)."""
        return sorted([*self._entries, *self._aliases])

    def __contains__(self, name: object) -> bool:
        return name in self._entries or name in self._aliases

    def __len__(self) -> int:
        return len(self._entries)
