"""Built-in simulator worlds and the world catalogue.

Each built-in world is a YAML file in this folder: a primitives world (``office``,
``warehouse``, ``campus``) or a ROS map_server map (``maze``: YAML + PGM).  Every world
defines a ``spawn`` pose and named ``waypoints`` that are reachable from it and at
least 0.6 m from any static obstacle.

``load_world`` accepts a built-in name or a path to either kind of YAML file; the two
are told apart by their keys (a map_server YAML has ``image``).
"""

from __future__ import annotations

from pathlib import Path

from navstack.core.errors import UnknownNameError
from navstack.sim.world import World

WORLDS_DIR = Path(__file__).resolve().parent


def list_worlds() -> list[str]:
    """Names of the built-in worlds, sorted."""
    return sorted(p.stem for p in WORLDS_DIR.glob("*.yaml"))


def world_path(name: str) -> Path:
    """Path of a built-in world's YAML; ``UnknownNameError`` lists the known names."""
    path = WORLDS_DIR / f"{name}.yaml"
    if "/" in name or "\\" in name or not path.is_file():
        raise UnknownNameError("world", name, list_worlds())
    return path


def _looks_like_path(text: str) -> bool:
    return text.endswith((".yaml", ".yml")) or "/" in text or "\\" in text


def load_world(name_or_path: str | Path) -> World:
    """A built-in world by name, or a world file (primitives or map_server YAML) by path."""
    from navstack.sim.world_io import load_world_file

    text = str(name_or_path)
    if isinstance(name_or_path, Path) or _looks_like_path(text) or Path(text).is_file():
        return load_world_file(Path(text))
    return load_world_file(world_path(text))


__all__ = ["WORLDS_DIR", "list_worlds", "load_world", "world_path"]
