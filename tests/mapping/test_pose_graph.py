"""Pose graph back end: gtsam's own optimum on the benchmark graphs, ISAM2 incremental with
loop closures, closed-form loops, serialization and typed errors."""

from __future__ import annotations

import math
from pathlib import Path

import gtsam
import numpy as np
import pytest

from navstack.core.geometry import se2_between, se2_compose
from navstack.mapping.g2o import G2oGraph, read_g2o, write_g2o
from navstack.mapping.pose_graph import (
    PoseGraph,
    PoseGraphError,
    PoseGraphParams,
    PoseGraphSolverError,
    UnknownNodeError,
)

DATA = Path(__file__).resolve().parents[1] / "data" / "g2o"
SIGMA = 1e-6          # PoseGraphParams().anchor_sigma


def _lm_params() -> gtsam.LevenbergMarquardtParams:
    prm = gtsam.LevenbergMarquardtParams()
    prm.setRelativeErrorTol(1e-10)
    prm.setAbsoluteErrorTol(1e-10)
    prm.setMaxIterations(200)
    return prm


def _gtsam_graph(path: Path) -> tuple[gtsam.NonlinearFactorGraph, gtsam.Values]:
    graph, initial = gtsam.readG2o(str(path), False)
    graph.add(gtsam.PriorFactorPose2(0, initial.atPose2(0),
                                     gtsam.noiseModel.Diagonal.Sigmas(np.full(3, SIGMA))))
    return graph, initial


@pytest.mark.parametrize(("name", "cost"), [("MIT", 385.1195), ("intel", 22.5021)])
def test_batch_optimum_equals_gtsams_own(name: str, cost: float) -> None:
    path = DATA / f"{name}.g2o"
    graph, initial = _gtsam_graph(path)
    reference = graph.error(gtsam.LevenbergMarquardtOptimizer(graph, initial,
                                                              _lm_params()).optimize())
    pg = PoseGraph.from_g2o(read_g2o(path))
    ours = pg.optimize()
    assert ours == pytest.approx(reference, rel=1e-6)
    assert ours == pytest.approx(cost, abs=1e-4)
    assert pg.error() == ours
    np.testing.assert_allclose(pg.pose(0), [0.0, 0.0, 0.0], atol=1e-15)     # anchored


def _incremental_gtsam(path: Path) -> float:
    """gtsam's own incremental run: ISAM2 (QR, same thresholds) node by node, each node
    initialised at its predecessor's estimate * odometry edge, then batch LM."""
    graph, _ = _gtsam_graph(path)
    prm = gtsam.ISAM2Params()
    prm.setRelinearizeThreshold(0.01)
    prm.relinearizeSkip = 1
    prm.setFactorization("QR")
    isam = gtsam.ISAM2(prm)
    by_newest: dict[int, list[gtsam.BetweenFactorPose2]] = {}
    odometry: dict[int, gtsam.Pose2] = {}
    prior = None
    for k in range(graph.size()):
        f = graph.at(k)
        if isinstance(f, gtsam.BetweenFactorPose2):
            i, j = f.keys()
            by_newest.setdefault(max(i, j), []).append(f)
            if j == i + 1:
                odometry.setdefault(j, f.measured())
        else:
            prior = f
    new = gtsam.NonlinearFactorGraph()
    new.add(prior)
    values = gtsam.Values()
    values.insert(0, gtsam.Pose2())
    isam.update(new, values)
    estimate = isam.calculateEstimate()
    for v in range(1, max(by_newest) + 1):
        new = gtsam.NonlinearFactorGraph()
        for f in by_newest[v]:
            new.add(f)
        values = gtsam.Values()
        values.insert(v, estimate.atPose2(v - 1).compose(odometry[v]))
        isam.update(new, values)
        estimate = isam.calculateEstimate()
    result = gtsam.LevenbergMarquardtOptimizer(graph, estimate, _lm_params()).optimize()
    return float(graph.error(result))


def _node_by_node(pg: PoseGraph, g: G2oGraph) -> None:
    """Add the graph's nodes in id order, each initialised at its predecessor's estimate
    * odometry edge, with all edges to earlier nodes, and ISAM2-update after each."""
    newest = np.maximum(g.edge_i, g.edge_j)
    pg.add_node(0, g.poses[0])
    pg.update()
    for v in range(1, g.num_vertices):
        ks = np.flatnonzero(newest == v)
        odo = next(k for k in ks if g.edge_i[k] == v - 1 and g.edge_j[k] == v)
        pg.add_node(v, se2_compose(pg.pose(v - 1), g.measurements[odo]))
        for k in ks:          # odometry plus loop closures back to old nodes
            pg.add_edge(g.edge_i[k], g.edge_j[k], g.measurements[k], g.information[k])
        pg.update()


def test_isam2_node_by_node_with_loop_closures_reaches_the_optimum() -> None:
    pg = PoseGraph()
    _node_by_node(pg, read_g2o(DATA / "MIT.g2o"))
    incremental_cost, incremental_poses = pg.error(), pg.poses()
    final = pg.optimize()
    assert final == pytest.approx(_incremental_gtsam(DATA / "MIT.g2o"), rel=1e-6)
    # ISAM2 alone was already at the optimum up to its relinearisation threshold
    assert incremental_cost == pytest.approx(final, rel=0.01)
    assert np.abs(incremental_poses[:, :2] - pg.poses()[:, :2]).max() < 0.05
    # Built this way the graph avoids the local minimum batch LM finds from the file's
    # raw odometry initial guess (385.12): the optimum is 20.6035.
    assert final == pytest.approx(20.6035, abs=1e-4)
    # later increments continue from the batch result (ISAM2 re-seeded)
    pg.add_node(10_000, se2_compose(pg.pose(807), [1.0, 0.0, 0.0]))
    pg.add_edge(807, 10_000, [1.0, 0.0, 0.0], np.eye(3))
    pg.update()
    assert pg.error() == pytest.approx(final, rel=1e-9)
    np.testing.assert_allclose(pg.pose(10_000), se2_compose(pg.pose(807), [1, 0, 0]),
                               atol=1e-9)


def test_cholesky_isam2_fails_on_mit_with_a_typed_error() -> None:
    """Why QR is the default: the loop closure 224 -> 165 (heading information 1.6e5
    against 1.8 in x) makes ISAM2's Cholesky factorization give up."""
    pg = PoseGraph(PoseGraphParams(factorization="CHOLESKY"))
    with pytest.raises(PoseGraphSolverError) as info:
        _node_by_node(pg, read_g2o(DATA / "MIT.g2o"))
    assert str(info.value).startswith("ISAM2 update failed: Indeterminate linear system "
                                      "detected while working near variable 165")
    assert pg.num_nodes == 225


def _square(loop: list[float], info: np.ndarray) -> PoseGraph:
    pg = PoseGraph()
    guesses = [[0, 0, 0], [1.2, 0.1, 1.4], [0.9, 1.1, 3.0], [-0.1, 0.8, -1.7]]
    for k, p in enumerate(guesses):
        pg.add_node(k, p)
    for k in range(3):
        pg.add_edge(k, k + 1, [1.0, 0.0, math.pi / 2], info)
    pg.add_edge(3, 0, loop, info)                                   # loop closure
    return pg


@pytest.mark.parametrize("incremental", [False, True])
def test_square_loop_closure_reaches_the_exact_square(incremental: bool) -> None:
    """Consistent measurements, perturbed initial guesses: the optimum is the unit square
    at cost 0.  ISAM2 stops relinearising below ``relinearize_threshold``, which leaves
    a few 1e-9 m of linearisation error."""
    pg = _square([1.0, 0.0, math.pi / 2], np.diag([100.0, 100.0, 400.0]))
    tol = 1e-7 if incremental else 1e-12
    if incremental:
        for _ in range(6):
            pg.update()
    else:
        pg.optimize()
    np.testing.assert_allclose(pg.poses(), [[0, 0, 0], [1, 0, math.pi / 2],
                                            [1, 1, math.pi], [0, 1, -math.pi / 2]],
                               atol=tol)
    assert pg.error() == pytest.approx(0.0, abs=tol**2 * 1e3)


def test_inconsistent_rotation_loop_spreads_the_error_evenly() -> None:
    """Turning on the spot four times by 90 deg while the loop closure says 90 deg + 0.2:
    with equal weights each of the 4 edges takes 0.05 rad of the 0.2 rad inconsistency,
    so the cost is 0.5 * 4 * I_theta * 0.05^2."""
    pg = PoseGraph()
    info = np.diag([50.0, 50.0, 100.0])
    for k in range(4):
        pg.add_node(k, [0.0, 0.0, 1.5 * k])
    for k in range(3):
        pg.add_edge(k, k + 1, [0.0, 0.0, math.pi / 2], info)
    pg.add_edge(3, 0, [0.0, 0.0, math.pi / 2 + 0.2], info)
    assert pg.optimize() == pytest.approx(0.5 * 4 * 100.0 * 0.05**2, rel=1e-9)
    expected = [math.remainder(k * (math.pi / 2 - 0.05), 2 * math.pi) for k in range(4)]
    np.testing.assert_allclose(pg.poses()[:, 2], expected, atol=1e-9)
    np.testing.assert_allclose(pg.poses()[:, :2], 0.0, atol=1e-12)


def test_serialization_round_trip_is_identical(tmp_path: Path) -> None:
    pg = PoseGraph.from_g2o(read_g2o(DATA / "MIT.g2o"))
    pg.optimize(max_iterations=5)
    data = pg.to_dict()
    assert all(isinstance(v, np.ndarray) for v in data.values())
    np.savez(tmp_path / "graph.npz", **data)
    back = PoseGraph.from_dict(dict(np.load(tmp_path / "graph.npz")))
    np.testing.assert_array_equal(back.node_ids, pg.node_ids)
    np.testing.assert_array_equal(back.poses(), pg.poses())
    assert back.error() == pg.error()
    for a, b in zip(back.edges, pg.edges, strict=True):
        np.testing.assert_array_equal(a, b)
    # and through the g2o writer: same graph, same cost at the same estimate
    write_g2o(pg.to_g2o(), tmp_path / "graph.g2o")
    again = PoseGraph.from_g2o(read_g2o(tmp_path / "graph.g2o"))
    assert again.error() == pytest.approx(pg.error(), rel=1e-12)


def test_bad_input_raises_typed_errors() -> None:
    pg = PoseGraph(PoseGraphParams(relinearize_threshold=0.05))
    pg.add_node(0, [0, 0, 0])
    pg.add_node(1, [1, 0, 0])
    with pytest.raises(PoseGraphError) as info:
        pg.add_node(1, [0, 0, 0])
    assert str(info.value) == "node 1 already exists; node ids must be unique"
    with pytest.raises(UnknownNodeError) as unknown:
        pg.add_edge(0, 5, [1, 0, 0], np.eye(3))
    assert str(unknown.value) == "edge 0 -> 5: node 5 does not exist; add_node it first"
    with pytest.raises(PoseGraphError) as info:
        pg.add_edge(0, 1, [1, 0, 0], np.diag([1.0, -1.0, 1.0]))
    assert str(info.value) == ("edge 0 -> 1: information matrix is not positive definite "
                               "(eigenvalues [-1.0, 1.0, 1.0]); pass the inverse of a "
                               "covariance with positive variances")
    with pytest.raises(PoseGraphError) as info:
        pg.add_edge(0, 1, [1, 0, math.nan], np.eye(3))
    assert str(info.value).startswith("edge 0 -> 1 measurement must be 3 finite numbers")
    with pytest.raises(PoseGraphError) as info:
        pg.add_node(-2, [0, 0, 0])
    assert str(info.value) == "node id -2 must be a non-negative integer"
    with pytest.raises(PoseGraphError) as info:      # bulk insert is all or nothing
        pg.add_edges([0, 1], [1, 0], [[1, 0, 0], [-1, 0, 0]],
                     [np.eye(3), [[1, 2, 0], [0, 1, 0], [0, 0, 1]]])
    assert str(info.value) == "edge 1 -> 0: information matrix is not symmetric"
    assert len(pg.edges.i) == 0 and pg.num_nodes == 2


def test_marginal_covariance_equals_gtsams_batch_marginals() -> None:
    """ISAM2's marginal of the newest node (what loop closure reads every scan) and of
    an old one match gtsam.Marginals on the same graph at the same estimate."""
    pg = PoseGraph()
    info = np.diag([400.0, 900.0, 2500.0])
    pg.add_node(0, [0.0, 0.0, 0.0])
    for k in range(1, 12):
        step = [1.0, 0.0, 0.3 if k % 3 else -0.2]
        pg.add_node(k, se2_compose(pg.pose(k - 1), step))
        pg.add_edge(k - 1, k, step, info)
        pg.update()
    open_chain = pg.marginal_covariance(11)
    # a closure close to what the chain says (ISAM2 linearises at its own estimate)
    closure = se2_compose(se2_between(pg.pose(2), pg.pose(11)), [0.02, -0.01, 0.005])
    pg.add_edge(2, 11, closure, info)
    for _ in range(3):
        pg.update()
    graph = gtsam.NonlinearFactorGraph()
    values = gtsam.Values()
    for k, p in enumerate(pg.poses()):
        values.insert(k, gtsam.Pose2(*p))
    graph.add(gtsam.PriorFactorPose2(0, gtsam.Pose2(0, 0, 0),
                                     gtsam.noiseModel.Isotropic.Sigma(3, SIGMA)))
    e = pg.edges
    for i, j, z, inf in zip(e.i, e.j, e.measurement, e.information, strict=True):
        graph.add(gtsam.BetweenFactorPose2(int(i), int(j), gtsam.Pose2(*z),
                                           gtsam.noiseModel.Gaussian.Information(inf)))
    marginals = gtsam.Marginals(graph, values)
    for node in (11, 5):
        np.testing.assert_allclose(pg.marginal_covariance(node),
                                   marginals.marginalCovariance(node), rtol=2e-2, atol=1e-6)
    # the closure to node 2 shrinks the uncertainty at the end of the chain
    assert np.all(np.diag(pg.marginal_covariance(11)) < 0.5 * np.diag(open_chain))


def test_removed_outlier_edge_leaves_the_consistent_square() -> None:
    info = np.diag([100.0, 100.0, 400.0])
    pg = _square([1.0, 0.0, math.pi / 2], info)
    bad = pg.add_edge(0, 2, [3.0, -2.0, 0.5], info, robust_kernel=1.0, kernel="dcs")
    pg.optimize()
    assert pg.edge_chi2(bad) > 100.0          # the outlier disagrees with everything
    pg.remove_edge(bad)
    for _ in range(5):
        pg.update()
    square = np.array([[0, 0, 0], [1, 0, math.pi / 2], [1, 1, math.pi], [0, 1, -math.pi / 2]])
    err = se2_between(square, pg.poses())
    np.testing.assert_allclose(err, 0.0, atol=1e-6)
    assert len(pg.edges.i) == 4 and pg.to_dict()["edge_robust_type"].tolist() == [0] * 4
    assert pg.edge_chi2(0) < 1e-9
    with pytest.raises(PoseGraphError, match="edge 4 does not exist or was already removed"):
        pg.remove_edge(bad)


def test_edge_chi2_of_an_inconsistent_loop() -> None:
    """Each of the four edges of the rotation loop takes 0.05 rad: chi2 = 100 * 0.05^2."""
    pg = PoseGraph()
    info = np.diag([50.0, 50.0, 100.0])
    for k in range(4):
        pg.add_node(k, [0.0, 0.0, 1.5 * k])
    edges = [pg.add_edge(k, k + 1, [0.0, 0.0, math.pi / 2], info) for k in range(3)]
    edges.append(pg.add_edge(3, 0, [0.0, 0.0, math.pi / 2 + 0.2], info, 2.0, "huber"))
    assert edges == [0, 1, 2, 3]
    pg.optimize()
    for k in edges:
        assert pg.edge_chi2(k) == pytest.approx(0.25, rel=1e-6)
    with pytest.raises(PoseGraphError, match="robust kernel 'tukey' is not one of cauchy"):
        pg.add_edge(0, 2, [0.0, 0.0, 0.0], info, 1.0, "tukey")  # type: ignore[arg-type]
