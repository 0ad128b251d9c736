"""``MapServer``: publishes a static map on ``/map`` (latched), like nav2_map_server.

The map comes from a map_server YAML file (``yaml_filename``, Nav2's parameter) or from an
``OccupancyGrid`` handed over directly (the simulator's true map when running with
perfect localization).  ``/map`` is transient-local so late subscribers get it.
"""

from __future__ import annotations

from dataclasses import replace

from navstack.core.map_files import load_map
from navstack.core.msgs import Header, OccupancyGrid
from navstack.runtime.node import Node, Runtime


class MapServer(Node):
    """Latched ``/map`` publisher; ``load(path)`` swaps the map at run time (LoadMap service)."""

    def __init__(self, runtime: Runtime, grid: OccupancyGrid | None = None,
                 yaml_filename: str = "", topic: str = "/map", frame_id: str = "map",
                 name: str = "map_server") -> None:
        super().__init__(name, runtime)
        if grid is None and not yaml_filename:
            raise ValueError("MapServer needs a map: pass grid= or yaml_filename=")
        self._grid = grid
        self.yaml_filename = yaml_filename
        self.topic = topic
        self.frame_id = frame_id

    def on_configure(self) -> None:
        if self._grid is None:
            self._grid = load_map(self.yaml_filename)
        self.pub = self.create_latched_publisher(self.topic, OccupancyGrid)

    def on_activate(self) -> None:
        self._publish()

    def load(self, yaml_filename: str) -> None:
        """Load another map file and publish it (nav2 ``load_map`` service)."""
        self._grid = load_map(yaml_filename)
        self.yaml_filename = yaml_filename
        self._publish()

    @property
    def grid(self) -> OccupancyGrid:
        assert self._grid is not None, "MapServer is not configured"
        return self._grid

    def _publish(self) -> None:
        grid = replace(self.grid, header=Header(self.now, self.frame_id))
        self._grid = grid
        self.pub.publish(grid)
