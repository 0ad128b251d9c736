"""navstack: an autonomous navigation stack for mobile robots.

Layers (imports only point down): interfaces -> missions -> navigation -> algorithms
(costmap, planning, control, localization, mapping, perception, geo) -> sim -> drivers ->
runtime -> core.  See ../shared/ARCHITECTURE.md and docs/.
"""

__version__ = "0.1.0"
