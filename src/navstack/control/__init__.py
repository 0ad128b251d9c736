"""navstack.control: local controllers and their helpers.

* :mod:`navstack.control.dwb` — DWB local planner (Nav2 ``dwb_core`` semantics).
* :mod:`navstack.control.goal_checker` — Simple/Stopped goal checkers.
* :mod:`navstack.control.progress_checker` — Simple/Pose/Goal progress checkers.

Submodules are imported explicitly (``from navstack.control.dwb import DWBLocalPlanner``)
so importing this package stays cheap.
"""
