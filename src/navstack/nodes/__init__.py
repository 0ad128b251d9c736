"""navstack.nodes: the node layer for state estimation and mapping.

Each module adapts one pure algorithm to the bus -- it subscribes, looks transforms up in
the runtime's TF buffer, calls the algorithm and publishes -- and holds nothing an
algorithm needs to run on its own (ARCHITECTURE.md §1: pure algorithms below, thin nodes
above):

* :mod:`.amcl` -- ``AmclNode`` (Nav2 ``amcl``) around
  :class:`~navstack.localization.amcl.AmclFilter`;
* :mod:`.ekf` -- ``EkfNode`` (robot_localization ``ekf_node`` / ``ukf_node``) around
  :class:`~navstack.localization.ekf.Ekf` / :class:`~navstack.localization.ekf.Ukf`;
* :mod:`.navsat` -- ``NavsatTransformNode`` (``navsat_transform_node``) around
  :class:`~navstack.localization.navsat.NavsatTransform`;
* :mod:`.initial_pose` -- ``InitialPoseNode`` (GNSS + magnetometer + scan matching ->
  ``/initialpose``) around :func:`~navstack.localization.initial_pose.estimate_initial_pose`;
* :mod:`.slam` -- ``SlamNode`` (slam_toolbox's sync/async nodes) around
  :class:`~navstack.mapping.slam.SlamMapper`.

The layer imports ``core``, ``runtime`` and the algorithm packages only; it sits beside
``navigation`` (the Nav2 servers and trees) and neither imports the other.  Nodes that
must wait for TF at a message's stamp use
:class:`~navstack.runtime.tf_filter.TfMessageFilter`.  Submodules are imported
explicitly (``from navstack.nodes.amcl import AmclNode``).
"""
