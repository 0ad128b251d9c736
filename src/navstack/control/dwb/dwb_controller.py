"""DWB local planner (``dwb_core::DWBLocalPlanner``), vectorised.

Each :meth:`DWBLocalPlanner.compute` cycle:

1. prunes the plan around the robot (``transformGlobalPlan``: poses passed more than
   ``prune_distance`` ago are dropped for good, the critics see the part within
   ``forward_prune_distance`` ahead, bounded by half the costmap size);
2. lets every critic ``prepare`` (distance maps, goal windows);
3. samples the dynamic window and rolls out all trajectories at once;
4. scores them critic by critic, dropping samples at their first rejection
   (``short_circuit_trajectory_evaluation``), and returns the lowest-total sample's
   velocity; if every sample is rejected it raises :class:`NoLegalTrajectories` naming
   how many samples each critic rejected and why.

Pose, velocity and plan are in the costmap's frame (the caller transforms; the local
costmap is usually in ``odom``).  ``last_evaluation`` keeps every scored trajectory with
per-critic scores for visualisation (``dwb_msgs/LocalPlanEvaluation``).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from navstack.control.dwb.critics import CriticContext, TrajectoryCritic, resolve_critic
from navstack.control.dwb.errors import InvalidPlan, NoLegalTrajectories
from navstack.control.dwb.params import DWBParams
from navstack.control.dwb.trajectory_generator import (
    TRAJECTORY_GENERATORS,
    StandardTrajectoryGenerator,
    TrajectoryBatch,
)
from navstack.core.errors import ConfigError, InvalidMessage, UnknownNameError
from navstack.core.interfaces import Controller
from navstack.core.msgs import Path, Pose2D, Twist2D
from navstack.core.plugins import register_controller
from navstack.core.polygon import Footprint
from navstack.costmap.costmap_2d import Costmap2D

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]


@dataclass
class DWBEvaluation:
    """Everything scored in one cycle (``dwb_msgs/LocalPlanEvaluation``).

    ``raw_scores`` ``(C, N)`` holds each critic's unscaled score (NaN where the critic
    was skipped or the sample was already rejected, negative where it rejected);
    ``totals`` ``(N,)`` the weighted sums (``inf`` for rejected samples);
    ``rejected_by`` ``(N,)`` the index of the first rejecting critic or -1.
    """

    batch: TrajectoryBatch
    critic_names: tuple[str, ...]
    critic_reasons: tuple[tuple[str, ...], ...]
    critic_scales: FloatArray
    raw_scores: FloatArray
    totals: FloatArray
    rejected_by: IntArray
    reject_codes: IntArray
    best_index: int
    transformed_plan: FloatArray
    prepare_failures: tuple[str, ...] = ()

    @property
    def velocities(self) -> FloatArray:
        return self.batch.velocities

    @property
    def best_velocity(self) -> Twist2D | None:
        if self.best_index < 0:
            return None
        vx, vy, wz = self.batch.velocities[self.best_index]
        return Twist2D(float(vx), float(vy), float(wz))

    @property
    def best_trajectory(self) -> FloatArray | None:
        """``(L, 3)`` poses of the chosen trajectory, or None if every sample was rejected."""
        if self.best_index < 0:
            return None
        return self.batch.poses[self.best_index, :self.batch.lengths[self.best_index]]

    def _reason(self, critic_index: int, code: int) -> str:
        reasons = self.critic_reasons[critic_index]
        return reasons[code - 1] if 0 < code <= len(reasons) else "rejected"

    def rejection_reason(self, index: int) -> str | None:
        """``"Critic (reason)"`` for a rejected sample, None for a legal one."""
        ci = int(self.rejected_by[index])
        if ci < 0:
            return None
        return f"{self.critic_names[ci]} ({self._reason(ci, int(self.reject_codes[index]))})"

    def critic_scores(self, index: int) -> dict[str, float]:
        """Raw per-critic scores of one sample (NaN = not evaluated)."""
        return {n: float(self.raw_scores[i, index]) for i, n in enumerate(self.critic_names)}

    def rejection_counts(self) -> dict[tuple[str, str], int]:
        """Samples rejected per ``(critic name, reason)``."""
        rejected = self.rejected_by >= 0
        pairs, counts = np.unique(
            np.column_stack((self.rejected_by[rejected], self.reject_codes[rejected])),
            axis=0, return_counts=True)
        return {(self.critic_names[int(ci)], self._reason(int(ci), int(code))): int(k)
                for (ci, code), k in zip(pairs, counts, strict=True)}


@register_controller("DWB", nav2="dwb_core::DWBLocalPlanner")
class DWBLocalPlanner(Controller):
    """The DWB controller: ``compute(pose, velocity, path, costmap, now) -> Twist2D``.

    ``params`` is a :class:`DWBParams` or a Nav2-layout mapping (``FollowPath``
    section); ``footprint`` is needed only by the ``ObstacleFootprint`` critic.
    """

    params_model = DWBParams
    params: DWBParams

    def __init__(self, params: DWBParams | Mapping[str, Any] | None = None, *,
                 footprint: Footprint | None = None) -> None:
        super().__init__(params if isinstance(params, DWBParams)
                         else DWBParams.from_mapping(params), footprint=footprint)
        try:
            gen_cls = TRAJECTORY_GENERATORS.get(self.params.trajectory_generator_name)
        except UnknownNameError as exc:
            raise ConfigError(str(exc), key_path="trajectory_generator_name") from None
        self.generator: StandardTrajectoryGenerator = gen_cls(self.params)
        self.critics: list[TrajectoryCritic[Any]] = self._load_critics(footprint)
        self._plan_msg: Path | None = None
        self._plan = np.zeros((0, 3))
        self._plan_start = 0
        self.last_evaluation: DWBEvaluation | None = None

    def _load_critics(self, footprint: Footprint | None) -> list[TrajectoryCritic[Any]]:
        out: list[TrajectoryCritic[Any]] = []
        for name in self.params.critics:
            section = dict(self.params.critic_params.get(name, {}))
            class_name = str(section.pop("class", name))
            try:
                cls = resolve_critic(class_name, self.params.default_critic_namespaces)
            except UnknownNameError as exc:
                raise ConfigError(str(exc), key_path=f"critics.{name}") from None
            out.append(cls(name, cls.make_params(section, key_path=name), self.params,
                           footprint))
        return out

    # --- plan -------------------------------------------------------------------------
    def set_plan(self, path: Path) -> None:
        """Take a new plan (``DWBLocalPlanner::setPlan``): resets critics and pruning."""
        self._plan_msg = path
        self._plan = path.as_array()
        self._plan_start = 0
        for critic in self.critics:
            critic.reset()
        self.generator.reset()

    def _accept_plan(self, path: Path | None, costmap: Costmap2D) -> None:
        if path is not None and path is not self._plan_msg:
            arr = path.as_array()
            if self._plan_msg is None or arr.shape != self._plan.shape or not np.array_equal(
                    arr, self._plan):
                self.set_plan(path)
            self._plan_msg = path
        if self._plan_msg is None:
            raise InvalidPlan("no plan: pass a path to compute() or call set_plan() first")
        frame = self._plan_msg.header.frame_id
        if frame and costmap.frame_id and frame != costmap.frame_id:
            raise InvalidPlan(
                f"plan is in frame '{frame}' but the costmap is in '{costmap.frame_id}'; "
                f"transform the plan (and pose) into '{costmap.frame_id}' before compute()")

    def transform_global_plan(self, pose: Pose2D, costmap: Costmap2D) -> FloatArray:
        """``transformGlobalPlan``: the part of the plan the critics see, ``(M, 3)``.

        With ``prune_plan`` the poses before the first one within ``prune_distance`` of
        the robot (searched over the first ``forward_prune_distance`` of plan length, then
        over the whole plan if none is there) are dropped permanently; the returned part
        ends at the first pose farther than ``forward_prune_distance``
        (``shorten_transformed_plan``), and never reaches past half the costmap size.
        """
        p = self.params
        plan = self._plan[self._plan_start:]
        if len(plan) == 0:
            raise InvalidPlan("received a plan with zero poses; replan")
        dist_threshold = max(costmap.size_x, costmap.size_y) * costmap.resolution / 2.0
        start_thr = min(dist_threshold, p.prune_distance) if p.prune_plan else dist_threshold
        end_thr = (min(dist_threshold, p.forward_prune_distance) if p.shorten_transformed_plan
                   else dist_threshold)
        seg = np.hypot(np.diff(plan[:, 0]), np.diff(plan[:, 1]))
        integrated = np.concatenate(([0.0], np.cumsum(seg)))
        beyond = np.nonzero(integrated > p.forward_prune_distance)[0]
        prune_point = int(beyond[0]) if len(beyond) else len(plan)
        d_robot = np.hypot(plan[:, 0] - pose.x, plan[:, 1] - pose.y)
        near = np.nonzero(d_robot[:prune_point] < start_thr)[0]
        if len(near) == 0:
            # navstack fallback: a plan handed over again (e.g. re-transformed into the
            # costmap frame) restarts pruning while the robot is far along it
            near = np.nonzero(d_robot < start_thr)[0]
        begin = int(near[0]) if len(near) else prune_point
        far = np.nonzero(d_robot[begin:] > end_thr)[0]
        end = begin + int(far[0]) if len(far) else len(plan)
        if p.prune_plan:
            self._plan_start += begin
        out = plan[begin:end]
        if len(out) == 0:
            raise InvalidPlan(
                f"no pose of the plan lies within {start_thr:.2f} m of the robot at "
                f"({pose.x:.2f}, {pose.y:.2f}); the robot has left the path — replan")
        return out

    # --- control ----------------------------------------------------------------------
    def set_speed_limit(self, limit: float, percentage: bool) -> None:
        """Nav2 speed limit: 0 = none; ``percentage`` of the maxima or absolute [m/s]."""
        self.generator.set_speed_limit(limit, percentage)

    def reset(self) -> None:
        """Clear critic state (oscillation flags, goal latches) and the last evaluation."""
        for critic in self.critics:
            critic.reset()
        self.generator.reset()
        self.last_evaluation = None

    def compute(self, pose: Pose2D, velocity: Twist2D, path: Path | None,
                costmap: Costmap2D, now: float = 0.0) -> Twist2D:
        """Best velocity command for this cycle; raises ``NoValidControl``/``InvalidPlan``.

        A ``path`` different from the current one acts as :meth:`set_plan` (Nav2's
        controller server calls ``setPlan`` on every new plan); ``None`` keeps it.
        """
        for v, what in ((pose.x, "pose.x"), (pose.y, "pose.y"), (pose.theta, "pose.theta")):
            if not math.isfinite(v):
                raise InvalidMessage(f"DWB compute: {what} is {v}; pose must be finite")
        if not velocity.is_finite():
            raise InvalidMessage(f"DWB compute: velocity {velocity} is not finite")
        self._accept_plan(path, costmap)
        plan = self.transform_global_plan(pose, costmap)
        g = self._plan[-1]
        batch = self.generator.generate(pose, velocity)
        ctx = CriticContext(pose, velocity, Pose2D(float(g[0]), float(g[1]), float(g[2])),
                            plan, costmap, now, batch)
        failures = tuple(c.name for c in self.critics if not c.prepare(ctx))
        evaluation = self._score(batch, ctx, plan, failures)
        self.last_evaluation = evaluation
        cmd = evaluation.best_velocity
        for critic in self.critics:
            critic.debrief(cmd or Twist2D(), ctx)
        if cmd is None:
            notes = tuple(f"{name} could not prepare (no plan pose on known costmap cells)"
                          for name in failures)
            raise NoLegalTrajectories(len(batch), evaluation.rejection_counts(), notes)
        return cmd

    def _score(self, batch: TrajectoryBatch, ctx: CriticContext, plan: FloatArray,
               failures: tuple[str, ...]) -> DWBEvaluation:
        n, c = len(batch), len(self.critics)
        scales = np.array([critic.get_scale() for critic in self.critics])
        raw = np.full((c, n), np.nan)
        totals = np.zeros(n)
        rejected_by = np.full(n, -1, dtype=np.int64)
        codes = np.zeros(n, dtype=np.int64)
        alive = np.arange(n)
        sub = batch
        # debug_trajectory_details keeps every critic's score of every sample for display
        short = (self.params.short_circuit_trajectory_evaluation
                 and not self.params.debug_trajectory_details)
        for ci, critic in enumerate(self.critics):
            if scales[ci] == 0.0 or len(alive) == 0:
                continue
            s = critic.score(sub, ctx)
            raw[ci, alive] = s
            bad = s < 0.0
            fresh = bad & (rejected_by[alive] < 0)
            rejected_by[alive[fresh]] = ci
            codes[alive[fresh]] = np.rint(-s[fresh]).astype(np.int64)
            totals[alive[~bad]] += s[~bad] * scales[ci]
            if short and bad.any():
                alive = alive[~bad]
                sub = batch.take(alive)
        legal = rejected_by < 0
        totals[~legal] = np.inf
        best = int(np.argmin(totals)) if legal.any() else -1
        return DWBEvaluation(batch, tuple(cr.name for cr in self.critics),
                             tuple(type(cr).reasons for cr in self.critics), scales, raw,
                             totals, rejected_by, codes, best, plan, failures)


DWBController = DWBLocalPlanner
"""Alias: the navstack name of the DWB controller."""
