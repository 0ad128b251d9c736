"""Web dashboard: live map, costmaps, scan, plans and robot in the browser; goals,
waypoints, cancel and a latched e-stop behind a token.  See ``docs/web_dashboard.md``."""

from navstack.interfaces.web.dashboard import (
    DashboardError,
    DashboardHandle,
    DashboardParams,
    serve_dashboard,
)

__all__ = ["DashboardError", "DashboardHandle", "DashboardParams", "serve_dashboard"]
