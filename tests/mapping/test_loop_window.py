"""A loop closure at the edge of its search window is not believed
(``loop_match_maximum_window_fraction``; issue 16, warehouse; docs/mapping.md "Loop
windows"): the correlative score still rose towards the edge, so the optimum may lie
outside the window -- in the warehouse's aisles such matches slid 1.1-1.4 m along the
racks with a good response."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navstack.benchmarks.slam_lds import lds_params
from navstack.mapping.fast_matcher import WideWindow
from navstack.mapping.loop_closure import LoopCandidate
from navstack.mapping.slam import SlamMapper
from navstack.mapping.slam_params import SlamParams
from navstack.mapping.submaps import Submap
from tests.mapping.sim_scans import LASER
from tests.mapping.sim_scans import ranges_at as _ranges


@pytest.mark.parametrize(("fraction", "offset", "found"),
                         [(0.0, 0.85, True), (0.8, 0.85, False), (0.8, 0.5, True)])
def test_a_closure_at_the_edge_of_its_window_is_rejected(office, fraction: float,
                                                         offset: float, found: bool) -> None:
    """The office corridor mapped with 12 scans, revisited at x = 3.2 m; the guess is
    ``offset`` metres along the corridor from the truth, the window +-1 m.  The match
    finds the true pose (within 5 cm) either way; 0.85 of the half-window from the guess
    is beyond ``loop_match_maximum_window_fraction`` 0.8 (counted as ``loop_window_edge``),
    0.5 is not, and 0 turns the test off."""
    params = SlamParams(minimum_time_interval=0.0, map_start_pose=[1.0, 7.5, 0.0],
                        do_loop_closing=False, loop_match_maximum_window_fraction=fraction)
    mapper = SlamMapper(params, LASER)
    for k in range(12):
        mapper.process_scan(_ranges(office, (1.0 + 0.5 * k, 7.5, 0.0)), (0.5 * k, 0.0, 0.0),
                            float(k))
    mapper.process_scan(_ranges(office, (3.2, 7.5, 0.0)), (2.2, 0.0, 0.0), 20.0)
    node = len(mapper.nodes) - 1
    loops = mapper.submaps
    submap = loops.submaps.complete()[0]
    truth_x = 3.2 - (1.0 + 0.5 * submap.anchor)  # the node in the anchor's frame
    guess = np.array([truth_x + offset, 0.0, 0.0])
    candidate = LoopCandidate(submap, guess, WideWindow(1.0, 1.0, 0.1), 0.0)
    closure = loops.match(node, candidate, mapper._poses)
    if found:
        assert closure is not None and not closure.corridor
        assert closure.measurement[0] == pytest.approx(truth_x, abs=0.05)
        assert abs(closure.measurement[1]) < 0.05
        assert mapper.stats.loop_window_edge == 0
    else:
        assert closure is None and mapper.stats.loop_window_edge == 1


def test_the_turtlebot3_searches_one_sigma_of_its_relative_uncertainty() -> None:
    """The graph's sigma was ~3x the real error in the warehouse exploration (seed 2: the
    guess 0.35 m off, sigma ~1.5 m); three sigmas made +-4-5 m windows that held the next
    rack 3.5 m along, and a closure one rack off was accepted.  The TurtleBot3's file
    searches one sigma: a 1.5 m sigma gives a +-1.5 m window (the default profile +-4.5 m),
    and a closure at its edge is not believed (0.8)."""
    tb3 = lds_params(np.zeros(3))
    assert tb3.loop_search_drift_sigmas == 1.0
    assert tb3.loop_match_maximum_window_fraction == 0.8
    poses = np.array([[0.0, 0.0, 0.0], [10.0, 0.0, 0.0]])
    covs = np.zeros((2, 3, 3))
    covs[0] = np.diag([1e-6, 1e-6, 1e-8])
    current = np.diag([1.5**2, 1.5**2, math.radians(2.0) ** 2])
    for params, half in ((tb3, 1.5), (SlamParams(), 4.5)):
        closer = SlamMapper(params, LASER).submaps
        cand = closer._candidate(Submap(0, [0]), poses[1], current, poses, covs, 0.0)
        assert cand.window.half_x == pytest.approx(half, rel=0.01)
        assert cand.window.half_y == pytest.approx(half, rel=0.01)
