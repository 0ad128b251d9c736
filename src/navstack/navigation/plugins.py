"""Loading the servers' plugins from their Nav2 parameter sections.

A server section names its plugins (``planner_plugins: ["GridBased"]``) and gives each a
section with a ``plugin:`` type string and the plugin's parameters::

    planner_server:
      ros__parameters:
        planner_plugins: ["GridBased"]
        GridBased:
          plugin: "nav2_navfn_planner/NavfnPlanner"
          tolerance: 0.5

:func:`plugin_section` splits a section into the type string and the parameters,
:func:`load_plugin` resolves the type string in one of the registries of
:mod:`navstack.core.plugins` (importing a built-in plugin's module on first use); the
server validates the parameters with the class's ``params_model`` and builds it.
Errors are :class:`~navstack.core.errors.ConfigError` naming the file and key path.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, TypeVar

from navstack.core.errors import ConfigError, PluginError, UnknownNameError, did_you_mean
from navstack.core.registry import ClassRegistry

P = TypeVar("P")


def plugin_section(server_params: Mapping[str, Any], name: str, default_plugin: str | None,
                   *, file: str = "", key_path: str = "") -> tuple[str, dict[str, Any]]:
    """``(plugin string, params without 'plugin')`` of the named plugin section.

    ``default_plugin`` is used when the section (or its ``plugin`` key) is absent;
    ``None`` makes ``plugin`` required.
    """
    raw = server_params.get(name) or {}
    if not isinstance(raw, Mapping):
        raise ConfigError(f"must be a mapping, got {type(raw).__name__}", file=file,
                          key_path=f"{key_path}.{name}")
    section = dict(raw)
    plugin = section.pop("plugin", default_plugin)
    if plugin is None:
        raise ConfigError("required key is missing", file=file,
                          key_path=f"{key_path}.{name}.plugin",
                          suggestion="give the plugin's type, e.g. plugin: \"pkg::Class\"")
    if not isinstance(plugin, str):
        raise ConfigError(f"must be a plugin type string, got {plugin!r}", file=file,
                          key_path=f"{key_path}.{name}.plugin")
    return plugin, section


def load_plugin(registry: ClassRegistry[P], plugin: str, *, file: str = "",
                key_path: str = "") -> type[P]:
    """The class registered for a Nav2 plugin string; ConfigError naming the key if the
    string is unknown or its module cannot provide it."""
    where = f"{key_path}.plugin" if key_path else "plugin"
    try:
        return registry.get(plugin)
    except UnknownNameError:
        hint = did_you_mean(plugin, registry.all_names()).strip(" ()")
        nav2_types = [n for n in registry.all_names() if "::" in n]
        raise ConfigError(f"unknown {registry.kind} plugin '{plugin}'", file=file,
                          key_path=where,
                          suggestion=hint or f"known: {', '.join(nav2_types)}; a plugin of "
                          f"your own: import its module first or write "
                          f"'package.module:ClassName'") from None
    except PluginError as exc:
        raise ConfigError(str(exc), file=file, key_path=where) from None

