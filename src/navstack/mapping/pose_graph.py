"""2D pose graph back end on gtsam (Dellaert & Kaess, "Factor Graphs for Robot
Perception", 2017), used by the SLAM engine the way slam_toolbox uses its Karto solver.

Nodes are robot poses ``(x, y, theta)`` of processed scans; an edge ``i -> j`` is a
scan-match or odometry constraint: the pose of ``j`` measured in the frame of ``i``
(``x_i^-1 * x_j``) with a 3x3 information matrix over ``(dx, dy, dtheta)`` in that same
frame — gtsam's ``BetweenFactorPose2`` and g2o's ``EDGE_SE2`` semantics.  The cost is
gtsam's ``0.5 * sum ||log(z^-1 * x_i^-1 * x_j)||^2_Info`` (:meth:`PoseGraph.error`).

Two ways to optimise:

* :meth:`PoseGraph.update` — incremental smoothing with ISAM2 (Kaess et al., IJRR 2012)
  of what was added since the last call: the per-scan path of online SLAM.  New loop
  closures (edges from a new node to an old one) are ordinary new factors; ISAM2
  re-eliminates the affected part of the Bayes tree and relinearises variables whose
  linear delta exceeds ``relinearize_threshold``.
* :meth:`PoseGraph.optimize` — batch Levenberg–Marquardt over the whole graph from the
  current estimate (tight tolerances), e.g. after a large loop closure or on a saved map.
  The result becomes the current estimate and ISAM2 is re-seeded from it lazily at the
  next :meth:`~PoseGraph.update`.

The gauge is fixed by priors: if none was added, the first node gets a prior at its
current pose with standard deviation ``anchor_sigma`` on x, y and theta when the graph
is first optimised, evaluated or serialised.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Literal, NamedTuple

import gtsam
import numpy as np
from numpy.typing import ArrayLike, NDArray
from pydantic import Field

from navstack.core.errors import NavstackError
from navstack.core.params import Params
from navstack.mapping.g2o import G2oGraph

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]


class PoseGraphError(NavstackError, ValueError):
    """A node, edge or prior cannot be added (bad id, shape, non-finite or not positive
    definite information) or a serialized graph is inconsistent."""


class UnknownNodeError(PoseGraphError, KeyError):
    """A node id that was never added to the graph."""

    def __str__(self) -> str:  # KeyError would quote the message
        return str(self.args[0])


class PoseGraphSolverError(PoseGraphError):
    """gtsam could not solve the linearised system (an unconstrained node, or a system too
    ill-conditioned for the chosen factorization)."""


def _solver_error(stage: str, exc: RuntimeError) -> PoseGraphSolverError:
    paragraphs = [" ".join(p.split()) for p in str(exc).strip().split("\n\n")]
    first = paragraphs[0] if paragraphs and paragraphs[0] else repr(exc)
    return PoseGraphSolverError(
        f"{stage} failed: {first} — every node needs a chain of edges to a prior (the first "
        "node is anchored automatically); an ill-conditioned graph needs factorization QR")


#: robust kernels of :meth:`PoseGraph.add_edge`, by code (the serialized form)
KERNELS: tuple[str, ...] = ("cauchy", "huber", "dcs")
RobustKernel = Literal["cauchy", "huber", "dcs"]
_M_ESTIMATORS = (gtsam.noiseModel.mEstimator.Cauchy.Create,
                 gtsam.noiseModel.mEstimator.Huber.Create,
                 gtsam.noiseModel.mEstimator.DCS.Create)


def _kernel_codes(kernel: str | ArrayLike, count: int, what: str) -> list[int]:
    if isinstance(kernel, str):
        if kernel not in KERNELS:
            raise PoseGraphError(f"{what}: robust kernel {kernel!r} is not one of "
                                 f"{', '.join(KERNELS)}")
        return [KERNELS.index(kernel)] * count
    codes = np.asarray(kernel).reshape(-1)
    if codes.shape != (count,) or not np.isin(codes, np.arange(len(KERNELS))).all():
        raise PoseGraphError(f"{what}: robust kernel codes must be {count} values in "
                             f"0..{len(KERNELS) - 1} ({', '.join(KERNELS)}), got "
                             f"{codes.tolist()}")
    return [int(c) for c in codes]


class PoseGraphParams(Params):
    """Solver settings.

    slam_toolbox exposes only its Ceres solver choices (``ceres_linear_solver``,
    ``ceres_trust_strategy`` ...); this back end is gtsam, so the names follow gtsam's
    ``ISAM2Params`` and ``LevenbergMarquardtParams``:

    * ``relinearize_threshold`` — ISAM2 ``relinearizeThreshold``: a variable is
      relinearised when its linear delta exceeds this (rad / m).  0.01 rather than
      gtsam's 0.1 default, because a loop closure in a long corridor moves old poses by
      small angles that still matter at the far end.
    * ``relinearize_skip`` — ISAM2 ``relinearizeSkip``: check for relinearisation every
      this many updates (1 = every scan; gtsam's default 10 suits high-rate odometry).
    * ``factorization`` — ISAM2 ``factorization``: QR by default.  CHOLESKY squares the
      condition number and fails ("indeterminate linear system") on real graphs: on
      MIT.g2o added node by node it breaks at the loop closure 224 -> 165 whose heading
      information is 1.6e5 next to 1.8 in x; QR solves it at the same speed.
    * ``anchor_sigma`` — std. dev. [m, m, rad] of the automatic prior on the first node.
    * ``relative_error_tol`` / ``absolute_error_tol`` — Levenberg–Marquardt stopping
      tolerances of :meth:`PoseGraph.optimize`.
    """

    relinearize_threshold: float = Field(0.01, gt=0.0)
    relinearize_skip: int = Field(1, ge=1)
    factorization: Literal["CHOLESKY", "QR"] = "QR"
    anchor_sigma: float = Field(1e-6, gt=0.0)
    relative_error_tol: float = Field(1e-10, ge=0.0)
    absolute_error_tol: float = Field(1e-10, ge=0.0)


class PoseGraphEdges(NamedTuple):
    """Edges as arrays: ``i``, ``j`` ``(M,)``, ``measurement`` ``(M, 3)``,
    ``information`` ``(M, 3, 3)``, in insertion order."""

    i: IntArray
    j: IntArray
    measurement: FloatArray
    information: FloatArray


def _pose3(value: ArrayLike, what: str) -> FloatArray:
    p = np.asarray(value, dtype=np.float64)
    if p.shape != (3,) or not np.isfinite(p).all():
        raise PoseGraphError(f"{what} must be 3 finite numbers (x, y, theta), got {value!r}")
    return p


def _informations(value: ArrayLike, whats: list[str]) -> FloatArray:
    """Validate ``(M, 3, 3)`` information matrices: finite, symmetric to 1e-9 relative,
    positive definite (gtsam's Gaussian noise model takes their Cholesky factors).  The
    error names the first bad one by ``whats[k]``."""
    info = np.asarray(value, dtype=np.float64)
    m = len(whats)
    if info.shape != (m, 3, 3):
        raise PoseGraphError(f"{whats[0] if m else 'edges'}: information must be a finite "
                             f"3x3 matrix, got shape {info.shape[1:] if m else info.shape}")
    finite = np.isfinite(info).all(axis=(1, 2))
    if not finite.all():
        k = int(np.argmin(finite))
        raise PoseGraphError(f"{whats[k]}: information must be a finite 3x3 matrix, "
                             f"got {info[k].tolist()}")
    scale = np.abs(info).max(axis=(1, 2))
    asym = np.abs(info - np.swapaxes(info, 1, 2)).max(axis=(1, 2)) > 1e-9 * scale
    if asym.any():
        raise PoseGraphError(f"{whats[int(np.argmax(asym))]}: information matrix is not "
                             "symmetric")
    info = 0.5 * (info + np.swapaxes(info, 1, 2))
    eig = np.linalg.eigvalsh(info) if m else np.zeros((0, 3))
    bad = eig[:, 0] <= 1e-12 * np.maximum(eig[:, 2], np.finfo(float).tiny)
    if bad.any():
        k = int(np.argmax(bad))
        raise PoseGraphError(f"{whats[k]}: information matrix is not positive definite "
                             f"(eigenvalues {eig[k].tolist()}); pass the inverse of a "
                             "covariance with positive variances")
    return info


class PoseGraph:
    """Incremental / batch 2D pose graph; see the module docstring."""

    def __init__(self, params: PoseGraphParams | None = None) -> None:
        self.params = params or PoseGraphParams()
        self._first: int | None = None
        self._ei: list[int] = []
        self._ej: list[int] = []
        self._meas: list[FloatArray] = []
        self._info: list[FloatArray] = []
        self._robust: list[float] = []
        self._kernel: list[int] = []
        self._prior_ids: list[int] = []
        self._prior_poses: list[FloatArray] = []
        self._prior_info: list[FloatArray] = []
        # every factor (edges and priors) in insertion order; removed ones stay as holes
        self._factors: list[gtsam.NonlinearFactor] = []
        self._active: list[bool] = []
        self._slot: list[int] = []          # ISAM2 factor index, -1 while not in ISAM2
        self._edge_factor: list[int] = []   # edge number -> factor number
        self._pending: list[int] = []       # factors to hand to ISAM2 at the next update
        self._to_remove: list[int] = []     # ISAM2 slots to remove at the next update
        self._graph_cache: gtsam.NonlinearFactorGraph | None = None
        self._values = gtsam.Values()
        self._stale = False                 # _values lags ISAM2 (refreshed lazily)
        self._poses_cache: FloatArray | None = None
        self._new_values = gtsam.Values()
        self._isam: gtsam.ISAM2 | None = None

    # --- building ----------------------------------------------------------------------
    def add_node(self, node_id: int, pose: ArrayLike) -> None:
        """Add node ``node_id`` (a non-negative int) with initial guess ``pose`` (3,)."""
        nid = int(node_id)
        if nid < 0 or nid != node_id:
            raise PoseGraphError(f"node id {node_id!r} must be a non-negative integer")
        if self._values.exists(nid):
            raise PoseGraphError(f"node {nid} already exists; node ids must be unique")
        p = _pose3(pose, f"pose of node {nid}")
        value = gtsam.Pose2(p[0], p[1], p[2])
        self._values.insert(nid, value)
        self._new_values.insert(nid, value)
        self._poses_cache = None
        if self._first is None:
            self._first = nid

    def add_edge(self, i: int, j: int, measurement: ArrayLike, information: ArrayLike,
                 robust_kernel: float = 0.0, kernel: RobustKernel = "cauchy") -> int:
        """Constraint: pose of node ``j`` in the frame of node ``i`` is ``measurement``
        (3,) with ``information`` (3, 3) over ``(dx, dy, dtheta)`` in frame ``i``.

        ``robust_kernel`` > 0 wraps the edge in a Cauchy M-estimator of that scale (in
        standard deviations): an edge that disagrees with the rest of the graph by many
        sigmas then pulls with a bounded force (loop closures; Sunderhauf & Protzel's
        observation that one false closure otherwise bends the whole map).  ``kernel``
        picks the M-estimator: ``cauchy``, ``huber`` or ``dcs`` (dynamic covariance
        scaling, Agarwal et al., ICRA 2013).  Returns the edge's number (for
        :meth:`remove_edge` and :meth:`edge_chi2`)."""
        return self.add_edges([i], [j], np.asarray(measurement, dtype=np.float64)[None],
                              np.asarray(information, dtype=np.float64)[None], [robust_kernel],
                              kernel)[0]

    def add_edges(self, i: ArrayLike, j: ArrayLike, measurements: ArrayLike,
                  information: ArrayLike, robust_kernel: ArrayLike | None = None,
                  kernel: RobustKernel | ArrayLike = "cauchy") -> list[int]:
        """Many edges at once (``(M,)``, ``(M,)``, ``(M, 3)``, ``(M, 3, 3)``, optional
        ``(M,)`` robust kernel scales, 0 = plain Gaussian, and the kernel name or ``(M,)``
        kernel codes of :data:`KERNELS`), validated in one vectorised pass; nothing is
        added if any edge is invalid.  Returns the new edges' numbers."""
        ii = np.asarray(i).reshape(-1)
        jj = np.asarray(j).reshape(-1)
        ii_int = [int(v) for v in ii]
        jj_int = [int(v) for v in jj]
        whats = [f"edge {a} -> {b}" for a, b in zip(ii_int, jj_int, strict=True)]
        if not whats:
            return []
        for a, b, what in zip(ii_int, jj_int, whats, strict=True):
            self._require(a, what)
            self._require(b, what)
            if a == b:
                raise PoseGraphError(f"{what} joins a node to itself")
        z = np.asarray(measurements, dtype=np.float64)
        if z.shape != (len(whats), 3) or not np.isfinite(z).all():
            bad = (int(np.argmin(np.isfinite(z).all(axis=1))) if z.shape == (len(whats), 3)
                   else 0)
            raise PoseGraphError(f"{whats[bad] if whats else 'edges'} measurement must be 3 "
                                 f"finite numbers (x, y, theta), got "
                                 f"{z[bad].tolist() if z.ndim == 2 else z.tolist()}")
        info = _informations(information, whats)
        robust = (np.zeros(len(whats)) if robust_kernel is None
                  else np.asarray(robust_kernel, dtype=np.float64).reshape(-1))
        if robust.shape != (len(whats),) or not (np.isfinite(robust) & (robust >= 0)).all():
            raise PoseGraphError(f"{whats[0]}: robust_kernel must be one finite number >= 0 "
                                 f"per edge, got {robust.tolist()}")
        codes = _kernel_codes(kernel, len(whats), whats[0])
        first = len(self._ei)
        for a, b, zk, ik, rk, code in zip(ii_int, jj_int, z, info, robust, codes, strict=True):
            gaussian = gtsam.noiseModel.Gaussian.Information(ik)
            noise = (gtsam.noiseModel.Robust.Create(_M_ESTIMATORS[code](float(rk)), gaussian)
                     if rk > 0 else gaussian)
            factor = gtsam.BetweenFactorPose2(a, b, gtsam.Pose2(zk[0], zk[1], zk[2]), noise)
            self._edge_factor.append(len(self._factors))
            self._push(factor)
        self._kernel.extend(codes)
        self._ei.extend(ii_int)
        self._ej.extend(jj_int)
        self._meas.extend(z.copy())
        self._info.extend(info)
        self._robust.extend(robust.tolist())
        return list(range(first, len(self._ei)))

    def _push(self, factor: gtsam.NonlinearFactor) -> None:
        self._pending.append(len(self._factors))
        self._factors.append(factor)
        self._active.append(True)
        self._slot.append(-1)
        self._graph_cache = None

    def remove_edge(self, edge: int) -> None:
        """Take edge number ``edge`` out of the graph (a loop closure found to be an
        outlier); ISAM2 drops it at the next :meth:`update`."""
        if not 0 <= edge < len(self._edge_factor) or not self._active[self._edge_factor[edge]]:
            raise PoseGraphError(f"edge {edge} does not exist or was already removed")
        f = self._edge_factor[edge]
        self._active[f] = False
        self._graph_cache = None
        if self._slot[f] >= 0:
            self._to_remove.append(self._slot[f])
            self._slot[f] = -1
        elif f in self._pending:
            self._pending.remove(f)

    def edge_chi2(self, edge: int) -> float:
        """Squared Mahalanobis norm of edge ``edge``'s error at the current estimate
        (without its robust kernel): about chi-square with 3 degrees of freedom when the
        edge agrees with the graph."""
        k = int(edge)
        if not 0 <= k < len(self._ei):
            raise PoseGraphError(f"edge {edge} does not exist")
        z = self._meas[k]
        xi, xj = self.pose(self._ei[k]), self.pose(self._ej[k])
        err = gtsam.Pose2.Logmap(gtsam.Pose2(z[0], z[1], z[2]).between(
            gtsam.Pose2(xi[0], xi[1], xi[2]).between(gtsam.Pose2(xj[0], xj[1], xj[2]))))
        e = np.asarray(err, dtype=np.float64)
        return float(e @ self._info[k] @ e)

    def marginal_covariance(self, node_id: int) -> FloatArray:
        """``(3, 3)`` marginal covariance of a node (x, y, theta in the node's own frame,
        gtsam's Pose2 tangent space) from ISAM2's Bayes tree.  Cheap for the newest node
        (it sits in the root clique), more expensive the older the node."""
        nid = int(node_id)
        self._require(nid, "marginal_covariance")
        if self._isam is None or self._pending or self._new_values.size():
            self.update()
        assert self._isam is not None
        return np.asarray(self._isam.marginalCovariance(nid), dtype=np.float64)

    def add_prior(self, node_id: int, pose: ArrayLike, information: ArrayLike) -> None:
        """Absolute constraint on node ``node_id`` (e.g. a known start or a GNSS fix)."""
        nid = int(node_id)
        what = f"prior on node {nid}"
        self._require(nid, what)
        p = _pose3(pose, f"{what} pose")
        info = _informations(np.asarray(information, dtype=np.float64)[None], [what])[0]
        factor = gtsam.PriorFactorPose2(nid, gtsam.Pose2(p[0], p[1], p[2]),
                                        gtsam.noiseModel.Gaussian.Information(info))
        self._push(factor)
        self._prior_ids.append(nid)
        self._prior_poses.append(p)
        self._prior_info.append(info)

    def _require(self, nid: int, what: str) -> None:
        if not self._values.exists(nid):
            raise UnknownNodeError(f"{what}: node {nid} does not exist; add_node it first")

    def _ensure_anchor(self) -> None:
        if not self._prior_ids and self._first is not None:
            sigma = self.params.anchor_sigma
            self.add_prior(self._first, self.pose(self._first), np.eye(3) / sigma**2)

    # --- optimisation ------------------------------------------------------------------
    def _isam2_params(self) -> gtsam.ISAM2Params:
        prm = gtsam.ISAM2Params()
        prm.setRelinearizeThreshold(self.params.relinearize_threshold)
        prm.relinearizeSkip = self.params.relinearize_skip
        prm.setFactorization(self.params.factorization)
        return prm

    def update(self) -> None:
        """Incremental ISAM2 step with the nodes, edges and priors added since the last
        update.  After :meth:`optimize` or :meth:`from_dict` the first call re-seeds ISAM2
        with the whole graph linearised at the current estimate."""
        self._ensure_anchor()
        try:
            if self._isam is None:
                self._sync()
                self._isam = gtsam.ISAM2(self._isam2_params())
                self._slot = [-1] * len(self._factors)
                added = [f for f, on in enumerate(self._active) if on]
                graph = gtsam.NonlinearFactorGraph()
                for f in added:
                    graph.add(self._factors[f])
                result = self._isam.update(graph, self._values)
            else:
                added = list(self._pending)
                graph = gtsam.NonlinearFactorGraph()
                for f in added:
                    graph.add(self._factors[f])
                result = self._isam.update(graph, self._new_values, self._to_remove)
            for f, slot in zip(added, result.getNewFactorsIndices(), strict=True):
                self._slot[f] = int(slot)
        except RuntimeError as exc:
            self._isam = None          # the next update re-seeds from the whole graph
            self._clear_pending()
            raise _solver_error("ISAM2 update", exc) from exc
        self._clear_pending()
        self._stale = True
        self._poses_cache = None

    def _sync(self) -> None:
        """Bring ``_values`` up to the ISAM2 estimate (nodes not yet handed to ISAM2 keep
        their initial guess)."""
        if not self._stale or self._isam is None:
            return
        estimate = self._isam.calculateEstimate()
        for key in self._values.keys():  # noqa: SIM118 (gtsam Values is not iterable)
            if not estimate.exists(key):
                estimate.insert(key, self._values.atPose2(key))
        self._values = estimate
        self._stale = False

    def _active_graph(self) -> gtsam.NonlinearFactorGraph:
        if self._graph_cache is None:
            graph = gtsam.NonlinearFactorGraph()
            for factor, on in zip(self._factors, self._active, strict=True):
                if on:
                    graph.add(factor)
            self._graph_cache = graph
        return self._graph_cache

    def optimize(self, max_iterations: int = 100) -> float:
        """Batch Levenberg–Marquardt from the current estimate; returns :meth:`error`.

        LM is local: from a poor initial guess it can stop in a local minimum.  MIT.g2o
        optimised from the file's raw-odometry vertices ends at cost 385.12 (gtsam alone
        does the same), while the same graph built node by node with :meth:`update`
        (each node initialised from its predecessor's estimate) reaches 20.60.
        """
        self._ensure_anchor()
        self._sync()
        prm = gtsam.LevenbergMarquardtParams()
        prm.setRelativeErrorTol(self.params.relative_error_tol)
        prm.setAbsoluteErrorTol(self.params.absolute_error_tol)
        prm.setMaxIterations(int(max_iterations))
        try:
            self._values = gtsam.LevenbergMarquardtOptimizer(self._active_graph(),
                                                             self._values, prm).optimize()
        except RuntimeError as exc:
            raise _solver_error("Levenberg-Marquardt", exc) from exc
        self._isam = None
        self._stale = False
        self._poses_cache = None
        self._clear_pending()
        return self.error()

    def _clear_pending(self) -> None:
        self._pending = []
        self._to_remove = []
        self._new_values = gtsam.Values()

    # --- queries -----------------------------------------------------------------------
    def error(self) -> float:
        """Total cost ``0.5 * sum of squared Mahalanobis norms`` at the current estimate."""
        self._ensure_anchor()
        self._sync()
        return float(self._active_graph().error(self._values))

    @property
    def num_nodes(self) -> int:
        return int(self._values.size())

    @property
    def node_ids(self) -> IntArray:
        """``(N,)`` node ids in increasing order (the row order of :meth:`poses`)."""
        return np.sort(np.array(list(self._values.keys()), dtype=np.int64))

    def poses(self) -> FloatArray:
        """``(N, 3)`` current estimate, rows in :attr:`node_ids` order."""
        if self._values.size() == 0:
            return np.zeros((0, 3))
        if self._poses_cache is None:
            self._sync()
            self._poses_cache = np.asarray(gtsam.utilities.extractPose2(self._values),
                                           dtype=np.float64)
        return self._poses_cache.copy()

    def pose(self, node_id: int) -> FloatArray:
        """Current estimate of one node, ``(3,)``."""
        nid = int(node_id)
        self._require(nid, "pose")
        if self._stale and self._isam is not None and self._isam.valueExists(nid):
            p = self._isam.calculateEstimatePose2(nid)
        else:
            p = self._values.atPose2(nid)
        return np.array([p.x(), p.y(), p.theta()])

    def _live_edges(self) -> list[int]:
        return [k for k, f in enumerate(self._edge_factor) if self._active[f]]

    @property
    def edges(self) -> PoseGraphEdges:
        """The edges in the graph (removed ones left out), in insertion order."""
        live = self._live_edges()
        m = len(live)
        return PoseGraphEdges(np.array([self._ei[k] for k in live], dtype=np.int64),
                              np.array([self._ej[k] for k in live], dtype=np.int64),
                              np.array([self._meas[k] for k in live],
                                       dtype=np.float64).reshape(m, 3),
                              np.array([self._info[k] for k in live],
                                       dtype=np.float64).reshape(m, 3, 3))

    # --- conversion --------------------------------------------------------------------
    @classmethod
    def from_g2o(cls, graph: G2oGraph, params: PoseGraphParams | None = None) -> PoseGraph:
        """Nodes and edges of a g2o graph; ``FIX`` vertices get an ``anchor_sigma`` prior
        (otherwise the first vertex is anchored automatically)."""
        pg = cls(params)
        for nid, pose in zip(graph.ids.tolist(), graph.poses, strict=True):
            pg.add_node(nid, pose)
        fix_info = np.eye(3) / pg.params.anchor_sigma**2
        for nid in graph.fixed.tolist():
            pg.add_prior(nid, pg.pose(nid), fix_info)
        pg.add_edges(graph.edge_i, graph.edge_j, graph.measurements, graph.information)
        return pg

    def to_g2o(self) -> G2oGraph:
        """The graph at its current estimate (priors are not part of the g2o format;
        the anchored first node is written as ``FIX``)."""
        e = self.edges
        fixed = np.array(sorted(set(self._prior_ids)), dtype=np.int64)
        return G2oGraph(self.node_ids, self.poses(), e.i, e.j, e.measurement,
                        e.information, fixed)

    def to_dict(self) -> dict[str, NDArray[np.generic]]:
        """Plain numpy arrays that :meth:`from_dict` turns back into the same graph.

        ``rotation_cos_sin`` stores gtsam's rotation exactly, so the restored estimate,
        :meth:`poses` and :meth:`error` are bit-identical.
        """
        self._ensure_anchor()
        self._sync()
        ids = self.node_ids
        rot = np.array([[r.c(), r.s()] for r in
                        (self._values.atPose2(int(k)).rotation() for k in ids)],
                       dtype=np.float64).reshape(-1, 2)
        e = self.edges
        n_p = len(self._prior_ids)
        return {
            "node_ids": ids,
            "poses": self.poses(),
            "rotation_cos_sin": rot,
            "edge_i": e.i,
            "edge_j": e.j,
            "edge_measurement": e.measurement,
            "edge_information": e.information,
            "edge_robust_kernel": np.array([self._robust[k] for k in self._live_edges()],
                                           dtype=np.float64),
            "edge_robust_type": np.array([self._kernel[k] for k in self._live_edges()],
                                         dtype=np.int64),
            "prior_ids": np.array(self._prior_ids, dtype=np.int64),
            "prior_poses": np.array(self._prior_poses, dtype=np.float64).reshape(n_p, 3),
            "prior_information": np.array(self._prior_info,
                                          dtype=np.float64).reshape(n_p, 3, 3),
        }

    @classmethod
    def from_dict(cls, data: Mapping[str, ArrayLike],
                  params: PoseGraphParams | None = None) -> PoseGraph:
        """Inverse of :meth:`to_dict`; the estimate is restored, ISAM2 re-seeds lazily."""
        missing = [k for k in ("node_ids", "poses", "rotation_cos_sin", "edge_i", "edge_j",
                               "edge_measurement", "edge_information", "prior_ids",
                               "prior_poses", "prior_information") if k not in data]
        if missing:
            raise PoseGraphError(f"serialized pose graph lacks {', '.join(missing)}")
        ids = np.asarray(data["node_ids"], dtype=np.int64)
        poses = np.asarray(data["poses"], dtype=np.float64).reshape(-1, 3)
        rot = np.asarray(data["rotation_cos_sin"], dtype=np.float64).reshape(-1, 2)
        if not len(ids) == len(poses) == len(rot):
            raise PoseGraphError(f"serialized pose graph has {len(ids)} node ids, "
                                 f"{len(poses)} poses and {len(rot)} rotations")
        pg = cls(params)
        for nid, p in zip(ids.tolist(), poses, strict=True):
            pg.add_node(nid, p)
        for nid, p, info in zip(np.asarray(data["prior_ids"]).tolist(),
                                np.asarray(data["prior_poses"]).reshape(-1, 3),
                                np.asarray(data["prior_information"]).reshape(-1, 3, 3),
                                strict=True):
            pg.add_prior(nid, p, info)
        pg.add_edges(data["edge_i"], data["edge_j"],
                     np.asarray(data["edge_measurement"]).reshape(-1, 3),
                     np.asarray(data["edge_information"]).reshape(-1, 3, 3),
                     np.asarray(data.get("edge_robust_kernel",
                                         np.zeros(len(np.asarray(data["edge_i"])))),
                                dtype=np.float64),
                     np.asarray(data.get("edge_robust_type",
                                         np.zeros(len(np.asarray(data["edge_i"])))),
                                dtype=np.int64))
        values = gtsam.Values()
        for nid, p, (c, s) in zip(ids.tolist(), poses, rot.tolist(), strict=True):
            values.insert(nid, gtsam.Pose2(gtsam.Rot2.fromCosSin(c, s),
                                           np.array([p[0], p[1]])))
        pg._values = values
        pg._clear_pending()
        return pg
