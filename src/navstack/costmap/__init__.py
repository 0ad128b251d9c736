"""navstack.costmap: Nav2-style layered costmaps (pure algorithms, no bus, no TF).

Start with :class:`~navstack.costmap.layered_costmap.LayeredCostmap` (or the builders
:func:`~navstack.costmap.builders.make_global_costmap` /
:func:`~navstack.costmap.builders.make_local_costmap`) and
:func:`~navstack.costmap.footprint.footprint_cost` for collision checks.
"""

from navstack.costmap.builders import make_global_costmap, make_local_costmap
from navstack.costmap.costmap_2d import (
    FREE_SPACE,
    INSCRIBED_INFLATED_OBSTACLE,
    LETHAL_OBSTACLE,
    MAX_NON_OBSTACLE,
    NO_INFORMATION,
    Costmap2D,
)
from navstack.costmap.footprint import footprint_cost, footprint_costs, make_footprint
from navstack.costmap.inflation_layer import InflationLayer, InflationLayerParams
from navstack.costmap.keepout_filter import KeepoutFilter, KeepoutFilterParams
from navstack.costmap.layer import Bounds, CellWindow, CostmapLayer, Layer
from navstack.costmap.layered_costmap import Costmap2DParams, LayeredCostmap
from navstack.costmap.observation_buffer import ObservationSourceParams
from navstack.costmap.obstacle_layer import (
    ObstacleLayer,
    ObstacleLayerParams,
    VoxelLayer,
    VoxelLayerParams,
)
from navstack.costmap.plugins import COSTMAP_LAYERS
from navstack.costmap.speed_filter import SpeedFilter, SpeedFilterParams
from navstack.costmap.static_layer import StaticLayer, StaticLayerParams

__all__ = [
    "COSTMAP_LAYERS", "FREE_SPACE", "INSCRIBED_INFLATED_OBSTACLE", "LETHAL_OBSTACLE",
    "MAX_NON_OBSTACLE", "NO_INFORMATION", "Bounds", "CellWindow", "Costmap2D",
    "Costmap2DParams", "CostmapLayer", "InflationLayer", "InflationLayerParams",
    "KeepoutFilter", "KeepoutFilterParams", "Layer", "LayeredCostmap", "ObservationSourceParams",
    "ObstacleLayer", "ObstacleLayerParams", "SpeedFilter", "SpeedFilterParams", "StaticLayer",
    "StaticLayerParams", "VoxelLayer", "VoxelLayerParams", "footprint_cost", "footprint_costs",
    "make_footprint", "make_global_costmap", "make_local_costmap",
]
