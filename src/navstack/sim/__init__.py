"""The built-in simulator: worlds, ray-cast lidar, footprint collision.

* :mod:`navstack.sim.world` — :class:`~navstack.sim.world.World`: a static occupancy grid
  plus deterministic moving obstacles, spawn pose and named waypoints;
* :mod:`navstack.sim.world_io` — building worlds from primitives YAML or ROS map files;
* :mod:`navstack.sim.worlds` — the built-in worlds (``office``, ``warehouse``,
  ``campus``, ``maze``) and ``load_world``;
* :mod:`navstack.sim.raycast` — exact grid traversal (Amanatides & Woo) lidar in numba;
* :mod:`navstack.sim.collision` — footprint collision and obstacle clearance.
"""
