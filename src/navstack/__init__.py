"""navstack: an autonomous navigation stack for mobile robots.

Layers (imports only point down): interfaces -> missions -> navigation and nodes (the node
layer: thin shells adapting algorithms to the bus) -> algorithms (costmap, planning,
control, localization, mapping, perception, geo; pure, no bus) -> core, with sim, drivers
and runtime below the node layer and never imported by an algorithm.  tests/test_layers.py
checks it.  See ../shared/ARCHITECTURE.md and docs/decisions.md.

``navstack.Navigator`` (the nav2_simple_commander-style API) is imported lazily so that
``import navstack`` stays light.
"""

from typing import Any

__version__ = "0.1.0"
__all__ = ["NavStack", "Navigator", "TaskResult", "__version__"]


def __getattr__(name: str) -> Any:
    if name in ("Navigator", "TaskResult"):
        from navstack.interfaces import api

        return getattr(api, name)
    if name == "NavStack":
        from navstack.interfaces.stack import NavStack

        return NavStack
    raise AttributeError(f"module 'navstack' has no attribute {name!r}")
