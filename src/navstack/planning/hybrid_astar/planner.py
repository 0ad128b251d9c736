"""``HybridAStar``: Nav2's Smac Hybrid-A* planner (``nav2_smac_planner::SmacPlannerHybrid``).

``HybridAStar(params, footprint, inflation=(radius, cost_scaling_factor)).plan(start,
goal, costmap, cancel=None) -> Path`` in the costmap frame.  What ``createPlan`` does
around the search is followed: optional costmap downsampling (max cost per block), start
/ goal conversion with typed errors, the trivial same-cell-and-bin plan, the search
with cancel / time checks every ``terminal_checking_interval`` expansions, the
best-within-tolerance fallback, then the smoother.  Paths are the lattice poses (one per
motion primitive, about ``sqrt(2)`` cells apart) followed by the analytic shot sampled
every half cell; orientations are the robot's heading (a reversing pose faces away from
its motion).  :meth:`HybridAStar.plan_detailed` also returns the unsmoothed path, the
travel direction of every pose and search statistics.

``inflation`` gives the costmap's inflation layer (Nav2 reads it from the layered
costmap): without it the planner cannot prove a pose far from obstacles from its centre
cost alone and checks the whole footprint at every sample, which is correct but slower.
"""

from __future__ import annotations

import math
import time

import numpy as np
from numpy.typing import NDArray

from navstack.core.errors import (
    GoalOccupied,
    GoalOutsideMap,
    NoValidPath,
    PlannerCancelled,
    PlannerTimeout,
    StartOccupied,
    StartOutsideMap,
)
from navstack.core.geometry import normalize_angle
from navstack.core.interfaces import CancelFn, GlobalPlanner
from navstack.core.msgs import Path, Pose2D
from navstack.core.plugins import register_planner
from navstack.core.polygon import Footprint
from navstack.costmap.costmap_2d import (
    INSCRIBED_INFLATED_OBSTACLE,
    NO_INFORMATION,
    Costmap2D,
)
from navstack.costmap.footprint import make_footprint
from navstack.costmap.inflation_kernel import cell_distance, cost_lut
from navstack.costmap.inflation_layer import InflationLayer
from navstack.costmap.layered_costmap import LayeredCostmap
from navstack.planning.budget import PlanningBudget
from navstack.planning.hybrid_astar import search as hs
from navstack.planning.hybrid_astar.checks import pose_collision
from navstack.planning.hybrid_astar.collision import (
    HEADING_STEP,
    SAMPLE_STEP,
    FootprintCells,
    poses_check,
    possible_collision_cost,
)
from navstack.planning.hybrid_astar.curves import DUBIN, REEDS_SHEPP
from navstack.planning.hybrid_astar.heuristics import (
    ObstacleHeuristic,
    fill_table,
    new_table,
    table_dims,
)
from navstack.planning.hybrid_astar.motion import MotionTable, build_motion_table
from navstack.planning.hybrid_astar.params import HybridAStarParams, TurningRadiusTooSmall
from navstack.planning.hybrid_astar.plan_types import (
    HybridPlan,
    downsample_max,
    fmt_heading,
    fmt_xy,
    heading_ranges,
)
from navstack.planning.hybrid_astar.smoother import smooth
from navstack.planning.hybrid_astar.workspace import SearchWorkspace


@register_planner("SmacPlannerHybrid", nav2="nav2_smac_planner::SmacPlannerHybrid")
class HybridAStar(GlobalPlanner):
    """Smac Hybrid-A*; see the module docstring."""

    name = "SmacPlannerHybrid"
    params_model = HybridAStarParams
    params: HybridAStarParams

    def __init__(self, params: HybridAStarParams | None = None,
                 footprint: Footprint | NDArray[np.float64] | None = None, *,
                 inflation: tuple[float, float] | None = None) -> None:
        super().__init__(params)
        if footprint is None:
            footprint = make_footprint()
        self.footprint = (footprint if isinstance(footprint, Footprint)
                          else Footprint.from_polygon(np.asarray(footprint, np.float64)))
        self.inflation = inflation
        p = self.params
        self.model = REEDS_SHEPP if p.motion_model_for_search == "REEDS_SHEPP" else DUBIN
        self.reverse_penalty = p.effective_reverse_penalty if self.model == REEDS_SHEPP \
            else max(p.reverse_penalty, 1.0)
        self._key: tuple[float, int, int] | None = None
        self._ws: SearchWorkspace | None = None
        self._oh = ObstacleHeuristic()
        self._no_start = np.zeros(4)
        self.last_plan: HybridPlan | None = None

    # --- configuration (Nav2 configure) ------------------------------------------------
    def set_footprint(self, footprint: Footprint,
                      inflation: tuple[float, float] | None = None) -> None:
        """Use another (padded) footprint and inflation ``(inflation_radius,
        cost_scaling_factor)``; Nav2 reads both from the costmap at every plan."""
        self.footprint = footprint
        self.inflation = inflation
        self._key = None

    def set_costmap_source(self, layered: LayeredCostmap) -> None:
        """Take footprint and inflation from a layered costmap (its first InflationLayer),
        as Nav2's plugin does from ``Costmap2DROS``."""
        self.configure(layered, layered.footprint)

    def configure(self, costmap: LayeredCostmap, footprint: Footprint) -> None:
        """Check ``footprint`` and read the inflation of ``costmap``'s first
        InflationLayer (the planner server's hook, Nav2 ``configure``)."""
        inflation = None
        for layer in costmap.layers:
            if isinstance(layer, InflationLayer):
                inflation = (layer.effective_inflation_radius,
                             layer.params.cost_scaling_factor)
                break
        self.set_footprint(footprint, inflation)

    def _grid(self, costmap: Costmap2D) -> tuple[NDArray[np.uint8], float, int]:
        p = self.params
        f = p.downsampling_factor if p.downsample_costmap else 1
        data = downsample_max(costmap.data, f) if f > 1 else costmap.data
        return data, costmap.resolution * f, f

    def prepare(self, costmap: Costmap2D, fill_distance_table: bool = True) -> None:
        """Build the resolution-dependent tables (Nav2 ``configure``): motion
        primitives, footprint cell sets, and (``fill_distance_table``) the whole Dubins /
        Reeds-Shepp lookup table, which otherwise fills lazily during plans."""
        data, res, f = self._grid(costmap)
        self._configure(res, f, costmap.resolution)
        if fill_distance_table:
            fill_table(self._table, self._floored, self.model, self._radius)
        self._workspace(data.shape[1], data.shape[0])

    def _configure(self, res: float, factor: int, costmap_res: float) -> None:
        p = self.params
        if p.minimum_turning_radius < res:
            raise TurningRadiusTooSmall(
                f"{p.minimum_turning_radius} m is smaller than one search-grid cell "
                f"({res:g} m = costmap resolution {costmap_res:g} m x downsampling factor "
                f"{factor}); a turn must leave its cell",
                key_path="minimum_turning_radius",
                suggestion=f"set minimum_turning_radius >= {res:g} or use a finer costmap")
        key = (res, p.angle_quantization_bins, self.model)
        if key == self._key:
            return
        bins = p.angle_quantization_bins
        self._radius = p.minimum_turning_radius / res
        self.motion: MotionTable = build_motion_table(
            self._radius, bins, self.model == REEDS_SHEPP, p.allow_primitive_interpolation)
        self.cells = FootprintCells(self.footprint.polygon, res, bins,
                                    covered_d2=self._covered_d2(res, factor))
        # a primitive's samples lie within its travel length of the parent pose: cells of
        # their footprint sets are within reach + travel + 2 half-diagonals of its cell
        sweep = self.cells.reach + float(self.motion.travel.max()) + math.sqrt(2.0)
        # ... and those between the ends within half a travel of one end
        mid = self.cells.reach + 0.5 * float(self.motion.travel.max()) + math.sqrt(2.0)
        self._sweep_border = self.cells.border + math.ceil(float(self.motion.travel.max())) + 1
        if self.inflation is not None:
            self._possible = possible_collision_cost(
                self.cells.reach, res, self.footprint.inscribed_radius, *self.inflation)
            self._sweep_cost = possible_collision_cost(
                sweep, res, self.footprint.inscribed_radius, *self.inflation)
            self._mid_cost = possible_collision_cost(
                mid, res, self.footprint.inscribed_radius, *self.inflation)
        else:
            self._possible = 0
            self._sweep_cost = 0
            self._mid_cost = 0
        size, floored, ceiling = table_dims(p.lookup_table_size, res)
        self._table = new_table(size, ceiling, bins)
        self._floored = floored
        self._max_len = p.analytic_expansion_max_length / res
        self._key = key

    def _covered_d2(self, res: float, factor: int) -> int:
        """Largest squared cell distance the inflation marks INSCRIBED, or -1.

        See :class:`FootprintCells` (``covered_d2``): only with the inflation known, no
        downsampling (a downsampled cell is the max of its block, whose distances are
        not the inflation's) and ``allow_unknown`` (unknown cells are not inflated).
        """
        if self.inflation is None or factor != 1 or not self.params.allow_unknown:
            return -1
        r_cells = cell_distance(self.inflation[0], res)
        if r_cells <= 0:
            return -1
        lut = cost_lut(r_cells, res, self.footprint.inscribed_radius, self.inflation[1])
        inscribed = np.nonzero(lut[:-1] >= INSCRIBED_INFLATED_OBSTACLE)[0]
        return int(inscribed.max()) if len(inscribed) else -1

    def _workspace(self, width: int, height: int) -> SearchWorkspace:
        bins = self.params.angle_quantization_bins
        ws = self._ws
        if ws is None or (ws.width, ws.height, ws.bins) != (width, height, bins):
            ws = self._ws = SearchWorkspace(width, height, bins)
        # samples SAMPLE_STEP cells and, on turns of radius >= R, HEADING_STEP bins apart
        arc_step = self._radius * HEADING_STEP * 2.0 * math.pi / bins
        ws.set_analytic_capacity(math.ceil(self._max_len / min(SAMPLE_STEP, arc_step)) + 16)
        return ws

    # --- planning ------------------------------------------------------------------------
    def plan(self, start: Pose2D, goal: Pose2D, costmap: Costmap2D,
             cancel: CancelFn | None = None) -> Path:
        """Plan from ``start`` to ``goal`` (both in ``costmap.frame_id``).

        Raises ``StartOutsideMap``, ``GoalOutsideMap``, ``StartOccupied``,
        ``GoalOccupied``, ``NoValidPath``, ``PlannerTimeout``, ``PlannerCancelled`` or
        ``TurningRadiusTooSmall``.
        """
        return self.plan_detailed(start, goal, costmap, cancel).path

    def _to_map(self, role: str, p: Pose2D, costmap: Costmap2D, res: float,
                data: NDArray[np.uint8]) -> tuple[float, float]:
        x = (p.x - costmap.origin_x) / res
        y = (p.y - costmap.origin_y) / res
        if not (0.0 <= x < data.shape[1] and 0.0 <= y < data.shape[0]):
            x1 = costmap.origin_x + costmap.size_x_m
            y1 = costmap.origin_y + costmap.size_y_m
            msg = (f"{role} {fmt_xy(p)} is outside the costmap, which spans x "
                   f"[{costmap.origin_x:.2f}, {x1:.2f}] y [{costmap.origin_y:.2f}, {y1:.2f}] "
                   f"in frame '{costmap.frame_id}'; give a {role} inside the map")
            raise (StartOutsideMap if role == "start" else GoalOutsideMap)(msg)
        return x, y

    def _blocked(self, role: str, p: Pose2D, grid: Costmap2D) -> str | None:
        """Why the footprint at ``p`` is in collision on the search grid, or None."""
        allow = self.params.allow_unknown
        c = grid.cost_at_world(p.x, p.y)
        if c == NO_INFORMATION and not allow:
            return f"{role} {fmt_xy(p)} is in unknown space (cost 255) and allow_unknown is false"
        if INSCRIBED_INFLATED_OBSTACLE <= c < NO_INFORMATION:
            return f"{role} {fmt_xy(p)} is in an obstacle (cost {c})"
        hit = pose_collision(grid, self.footprint.polygon, (p.x, p.y, p.theta), allow)
        if hit is None:
            return None
        where = ("the footprint leaves the map" if hit == (-1, -1) else
                 "the footprint overlaps the {} cell at ({:.2f}, {:.2f})".format(
                     "unknown" if int(grid.data[hit[1], hit[0]]) == NO_INFORMATION else "lethal",
                     *grid.map_to_world(*hit)))
        return f"{role} {fmt_xy(p)} at heading {fmt_heading(p.theta)}: {where}"

    def _free_headings(self, p: Pose2D, grid: Costmap2D) -> list[int]:
        """Heading bins at which the footprint at ``p`` is collision-free."""
        bins = self.params.angle_quantization_bins
        return [b for b in range(bins)
                if pose_collision(grid, self.footprint.polygon,
                                  (p.x, p.y, b * 2.0 * math.pi / bins),
                                  self.params.allow_unknown) is None]

    def plan_detailed(self, start: Pose2D, goal: Pose2D, costmap: Costmap2D,
                      cancel: CancelFn | None = None) -> HybridPlan:
        """:meth:`plan` returning the :class:`HybridPlan` (also kept as ``last_plan``)."""
        t0 = time.perf_counter()
        p = self.params
        data, res, f = self._grid(costmap)
        self._configure(res, f, costmap.resolution)
        grid = costmap if f == 1 else Costmap2D.from_array(
            data, res, costmap.origin_x, costmap.origin_y, costmap.frame_id)
        sx, sy = self._to_map("start", start, costmap, res, data)
        gx, gy = self._to_map("goal", goal, costmap, res, data)
        why = self._blocked("start", start, grid)
        if why is not None:
            raise StartOccupied(why + "; clear the costmap or move the robot into free space")
        why = self._blocked("goal", goal, grid)
        if why is not None and p.tolerance <= 0.0:
            free = self._free_headings(goal, grid)
            hint = ("no heading fits there" if not free else
                    "the footprint fits there at headings "
                    f"{heading_ranges(free, p.angle_quantization_bins)} deg")
            raise GoalOccupied(f"{why} ({hint}); choose a free goal pose or raise tolerance")
        bins = p.angle_quantization_bins
        bin_size = 2.0 * math.pi / bins
        s_bin = round(normalize_angle(start.theta) / bin_size) % bins
        g_bin = round(normalize_angle(goal.theta) / bin_size) % bins
        if int(sx) == int(gx) and int(sy) == int(gy) and s_bin == g_bin:
            xyt = np.array([[start.x, start.y, goal.theta]])
            path = Path.from_array(xyt, frame_id=costmap.frame_id)
            ms = (time.perf_counter() - t0) * 1e3
            plan = HybridPlan(path, xyt, xyt, np.ones(1, np.int8), 0, False, True, 0.0, ms)
            self.last_plan = plan
            return plan

        ws = self._workspace(data.shape[1], data.shape[0])
        g_cell = (int(gx), int(gy))
        cache_key = ((g_cell, data.shape, res, costmap.origin_x, costmap.origin_y,
                      p.cost_penalty, p.allow_unknown, p.use_quadratic_cost_penalty,
                      p.downsample_obstacle_heuristic) if p.cache_obstacle_heuristic else None)
        self._oh.reset(data, g_cell, p.downsample_obstacle_heuristic, p.cost_penalty,
                       p.allow_unknown, p.use_quadratic_cost_penalty, cache_key,
                       p.tolerance / res)
        ip, fp = self._search_params(data, g_cell, g_bin, gx, gy, goal.theta)
        m, oh = self.motion, self._oh
        hs.search_run(0, np.array([sx, sy, start.theta, s_bin], dtype=np.float64), data, ip, fp,
                     m.dx, m.dy, m.dbin, m.turn, m.reverse, m.travel, m.samples, m.n_samples,
                     self.cells.off_x, self.cells.off_y, self.cells.starts, oh.weight, oh.dist,
                     oh.stamp, oh.hkey, oh.hnode, oh.hpos, oh.state, self._table, ws.nodes,
                     ws.cells, ws.blocks, ws.block_h, ws.hk, ws.hn, ws.abest, ws.adir, ws.acost,
                     ws.ascr, ws.asdir, ws.ascost, ws.istate, ws.fstate)
        h0 = float(ws.fstate[hs.F_H0])
        if h0 == math.inf:
            raise NoValidPath(
                f"no valid path from start {fmt_xy(start)} to goal {fmt_xy(goal)}: the goal is not "
                f"reachable through cells cheaper than INSCRIBED (253) even for a point robot; "
                f"check the costmap for a blocked passage" + ("" if p.allow_unknown else
                                                               " or set allow_unknown"))
        status = self._run(ws, data, ip, fp, start, goal, cancel, t0)
        t_search = time.perf_counter()
        xyt, direction, analytic, reached = self._result(ws, status, start, goal, res, grid)
        xyt[:, 0] = costmap.origin_x + xyt[:, 0] * res
        xyt[:, 1] = costmap.origin_y + xyt[:, 1] * res
        xyt[0] = (start.x, start.y, start.theta)
        raw = xyt.copy()
        raw[:, 2] = normalize_angle(raw[:, 2])
        smoothed = raw
        if p.smooth_path and len(raw) > 2:
            smoothed = self._smooth(raw, direction, data, res, costmap)
        path = Path.from_array(smoothed, frame_id=costmap.frame_id)
        t1 = time.perf_counter()
        plan = HybridPlan(path, raw, smoothed, direction, int(ws.istate[hs.I_ITER]), analytic,
                          reached, (t_search - t0) * 1e3, (t1 - t0) * 1e3,
                          {"nodes": float(ws.istate[hs.I_NODES])})
        self.last_plan = plan
        return plan

    def _search_params(self, data: NDArray[np.uint8], g_cell: tuple[int, int], g_bin: int,
                       gx: float, gy: float, g_theta: float
                       ) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
        p = self.params
        ip = np.zeros(hs.N_IP, dtype=np.int64)
        ip[hs.IP_MODEL] = self.model
        ip[hs.IP_ALLOW_UNKNOWN] = int(p.allow_unknown)
        ip[hs.IP_POSSIBLE] = self._possible
        ip[hs.IP_BORDER] = self.cells.border
        ip[hs.IP_GOAL_CELL] = g_cell[1] * data.shape[1] + g_cell[0]
        ip[hs.IP_GOAL_BIN] = g_bin
        ip[hs.IP_MAX_APPROACH] = p.max_on_approach_iterations if p.max_on_approach_iterations > 0 \
            else 2**62
        ip[hs.IP_OVERRIDE] = int(p.analytic_expansion_max_cost_override)
        ip[hs.IP_FLOORED] = self._floored
        ip[hs.IP_WD] = self._oh.shape[1]
        ip[hs.IP_DOWN] = 2 if p.downsample_obstacle_heuristic else 1
        ip[hs.IP_BINS] = p.angle_quantization_bins
        ip[hs.IP_QUAD] = int(p.use_quadratic_cost_penalty)
        ip[hs.IP_SWEEP_COST] = self._sweep_cost
        ip[hs.IP_SWEEP_BORDER] = self._sweep_border
        ip[hs.IP_MID_COST] = self._mid_cost
        fp = np.zeros(hs.N_FP)
        fp[hs.FP_REWARD] = 1.0 - p.retrospective_penalty
        fp[hs.FP_COST_PEN] = p.cost_penalty
        fp[hs.FP_NSP] = p.non_straight_penalty
        fp[hs.FP_CHP] = p.change_penalty
        fp[hs.FP_REVP] = self.reverse_penalty
        fp[hs.FP_RATIO] = p.analytic_expansion_ratio
        fp[hs.FP_MAXLEN] = self._max_len
        fp[hs.FP_MAXCOST] = p.analytic_expansion_max_cost
        fp[hs.FP_TOL] = p.tolerance / self._grid_res()  # in cells, as Nav2
        fp[hs.FP_RADIUS] = self._radius
        fp[hs.FP_GX], fp[hs.FP_GY], fp[hs.FP_GTH] = gx, gy, g_theta
        fp[hs.FP_STEP] = SAMPLE_STEP
        return ip, fp

    def _grid_res(self) -> float:
        assert self._key is not None
        return self._key[0]

    def _run(self, ws: SearchWorkspace, data: NDArray[np.uint8], ip: NDArray[np.int64],
             fp: NDArray[np.float64], start: Pose2D, goal: Pose2D, cancel: CancelFn | None,
             t0: float) -> int:
        p = self.params
        what = f"planning from start {fmt_xy(start)} to goal {fmt_xy(goal)}"
        limit = p.max_iterations if p.max_iterations > 0 else 2**62
        m, oh = self.motion, self._oh
        # the first call of a process compiles the kernel (or loads it from the numba
        # cache): the time budget starts once it has returned
        compiling = not hs.search_run.signatures
        budget_clock = PlanningBudget(p.max_planning_time, p.sim_expansion_rate,
                                      self.simulated_time)
        budget_clock.restart(t0)  # Nav2 counts the heuristic set-up too
        self._budget = budget_clock
        # on simulated time the search stops at exactly the expansion budget
        sim_cap = budget_clock.max_expansions
        while True:
            if cancel is not None and cancel():
                raise PlannerCancelled(f"{what} was cancelled after "
                                       f"{int(ws.istate[hs.I_ITER])} expansions")
            it = int(ws.istate[hs.I_ITER])
            budget = min(p.terminal_checking_interval, limit - it)
            if budget <= 0:
                return -1
            if sim_cap is not None:
                if sim_cap - it <= 0:
                    return -2
                budget = min(budget, sim_cap - it)
            status = hs.search_run(
                budget, self._no_start, data, ip, fp, m.dx, m.dy, m.dbin, m.turn, m.reverse,
                m.travel, m.samples, m.n_samples, self.cells.off_x, self.cells.off_y,
                self.cells.starts, oh.weight, oh.dist, oh.stamp, oh.hkey, oh.hnode, oh.hpos,
                oh.state, self._table, ws.nodes, ws.cells, ws.blocks, ws.block_h, ws.hk, ws.hn,
                ws.abest, ws.adir, ws.acost, ws.ascr, ws.asdir, ws.ascost, ws.istate, ws.fstate)
            if compiling:
                budget_clock.restart()
                compiling = False
            if status == hs.GROW:
                ws.grow()
                continue
            if status != hs.RUNNING:
                return status
            if sim_cap is None and budget_clock.exceeded(int(ws.istate[hs.I_ITER])):
                return -2

    def _result(self, ws: SearchWorkspace, status: int, start: Pose2D, goal: Pose2D,
                res: float, grid: Costmap2D
                ) -> tuple[NDArray[np.float64], NDArray[np.int8], bool, bool]:
        p = self.params
        it = int(ws.istate[hs.I_ITER])
        rev = self.motion.reverse
        if status == hs.FOUND_ANALYTIC:
            node = int(ws.istate[hs.I_ANA_NODE])
            n = int(ws.istate[hs.I_ANA_N])
            xyt, direction = hs.backtrace(node, ws.nodes, rev)
            xyt = np.vstack((xyt, ws.abest[:n]))
            direction = np.concatenate((direction, ws.adir[:n]))
            if len(direction) > 1 and node == 0:
                direction[0] = direction[1]
            return xyt, direction, True, True
        if status == hs.FOUND:
            node = int(ws.istate[hs.I_RESULT])
            xyt, direction = hs.backtrace(node, ws.nodes, rev)
            return xyt, direction, False, True
        best = int(ws.istate[hs.I_BEST])
        if best >= 0 and ws.fstate[hs.F_BEST_H] < p.tolerance / res:
            xyt, direction = hs.backtrace(best, ws.nodes, rev)
            return xyt, direction, False, False
        what = f"from start {fmt_xy(start)} to goal {fmt_xy(goal)}"
        if status == -1:
            raise PlannerTimeout(
                f"planning {what} exceeded max_iterations {p.max_iterations} without reaching "
                f"the goal or a pose within tolerance {p.tolerance:.2f} m; raise "
                f"max_iterations (or set it to -1) or tolerance")
        if status == -2:
            raise PlannerTimeout(
                f"planning {what} exceeded {self._budget.describe(it)} without reaching "
                f"the goal or a pose within tolerance {p.tolerance:.2f} m; raise "
                f"max_planning_time or tolerance")
        bins = p.angle_quantization_bins
        gcx = int((goal.x - grid.origin_x) / res)
        gcy = int((goal.y - grid.origin_y) / res)
        reached = self._closed_bins(ws, gcy * grid.size_x + gcx)
        if len(reached):
            heads = heading_ranges(reached, bins)
            raise NoValidPath(
                f"no valid path {what} at goal heading {fmt_heading(goal.theta)}: the goal "
                f"position is reachable only at headings {heads} deg (kinematically, with "
                f"minimum_turning_radius {p.minimum_turning_radius} m and "
                f"{p.motion_model_for_search}); choose a reachable goal heading, raise "
                f"tolerance or use REEDS_SHEPP")
        why = self._blocked("goal", goal, grid)
        if why is not None:
            raise GoalOccupied(f"{why}, and no collision-free pose within tolerance "
                               f"{p.tolerance:.2f} m was reached; choose a free goal pose")
        raise NoValidPath(
            f"no valid path {what} at goal heading {fmt_heading(goal.theta)}: every pose "
            f"reachable with minimum_turning_radius {p.minimum_turning_radius} m "
            f"({p.motion_model_for_search}) was searched ({it} expansions); check the "
            f"costmap for a passage too narrow for the footprint, or use REEDS_SHEPP")

    @staticmethod
    def _closed_bins(ws: SearchWorkspace, cell: int) -> NDArray[np.int64]:
        """Bins of ``cell`` whose node was expanded in the last search."""
        if int(ws.cells[cell, 0]) != int(ws.istate[hs.I_GEN]):
            return np.zeros(0, dtype=np.int64)
        ids = ws.blocks[int(ws.cells[cell, 1])]
        return np.nonzero(ids <= -2)[0]  # closed nodes are stored as -2 - id

    def _smooth(self, raw: NDArray[np.float64], direction: NDArray[np.int8],
                data: NDArray[np.uint8], res: float, costmap: Costmap2D) -> NDArray[np.float64]:
        p = self.params
        sp = p.smoother
        cells = raw.copy()
        cells[:, 0] = (raw[:, 0] - costmap.origin_x) / res
        cells[:, 1] = (raw[:, 1] - costmap.origin_y) / res
        passes = 1 + (sp.refinement_num if sp.do_refinement else 0)
        out = smooth(cells, direction, kappa_max=1.0 / self._radius, w_data=sp.w_data,
                     w_smooth=sp.w_smooth, tolerance=sp.tolerance, max_its=sp.max_iterations,
                     passes=passes, res=res, bins=p.angle_quantization_bins, data=data,
                     off_x=self.cells.off_x, off_y=self.cells.off_y, starts=self.cells.starts,
                     border=self.cells.border, possible_cost=self._possible,
                     allow_unknown=p.allow_unknown)
        out[:, 0] = costmap.origin_x + out[:, 0] * res
        out[:, 1] = costmap.origin_y + out[:, 1] * res
        out[:, 2] = normalize_angle(out[:, 2])
        return out

    def check_poses(self, xyt: NDArray[np.float64], costmap: Costmap2D) -> NDArray[np.int64]:
        """The planner's own (conservative) check of world poses: centre cost or -1."""
        data, res, f = self._grid(costmap)
        self._configure(res, f, costmap.resolution)
        cells = np.array(xyt, dtype=np.float64).reshape(-1, 3)
        cells[:, 0] = (cells[:, 0] - costmap.origin_x) / res
        cells[:, 1] = (cells[:, 1] - costmap.origin_y) / res
        return poses_check(data, cells, self.params.angle_quantization_bins, self.cells.off_x,
                           self.cells.off_y, self.cells.starts, self.cells.border,
                           self._possible, self.params.allow_unknown)
