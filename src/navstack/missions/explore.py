"""Frontier exploration as mission behaviours: ``Escape``, ``Explore`` and the explore
mission (explore_lite's node, on navstack's decision loop).

``Explore`` runs :class:`~navstack.exploration.explorer.FrontierExplorer` at
``planner_frequency`` on the costmap topic (explore_lite's ``costmap_topic``, the global
costmap by default) and sends its goals as NavigateToPose goals; a new goal preempts the
running one in place (the navigator replans without stopping).  Goals face the way the
robot drives to them (explore_lite sends yaw 0, which costs a final turn at every
frontier).  When ``visualize`` is on it publishes explore_lite's markers on
``explore/frontiers``: each frontier's cells as POINTS (blue; red when blacklisted,
grey when unreachable) and a SPHERE at its goal (green, larger for better).

``Escape`` handles a start against an obstacle (explore_lite's "starting facing a wall"):
when an observed obstacle on ``map_topic`` -- or a lethal cell of the local costmap, what
the controller judges its arcs on -- is closer than the robot's turning radius
(``circumscribed_radius``), turning in place would hit it, so the robot first backs away
(or drives forward when the obstacle is behind it).  ``Explore`` runs the same escape
after a goal it gave up (stuck) or the navigator aborted, before the next goal: a robot
wedged at a box corner -- its padded footprint on a lethal cell, so the controller
refuses to move and the spin recovery cannot turn it -- otherwise stays there.  The
mission escapes once more before returning home.  When both straight moves were
refused (obstacles ahead and behind: a turn in place that ended between two), the
escape turns ``spin_angle`` away from the nearest obstacle -- the behaviour server
refuses a turn that would hit anything -- and tries straight moves again; the next
turn goes the other way.  A goal whose frontier was observed on the way is replaced in
place, without stopping or escaping (explore_lite's ``makePlan`` does the same).

:func:`explore_mission` is explore_lite's node: wait for the map, remember the start
pose, escape, explore, and with ``return_to_init`` return to the start pose -- a checked
part of the mission here (explore_lite fires one goal and forgets it).
"""

from __future__ import annotations

import math
from collections.abc import Sequence as Seq
from typing import Any

import numpy as np
from py_trees.common import Status
from py_trees.composites import Sequence

from navstack.core.msgs import (
    ColorRGBA,
    Header,
    Marker,
    MarkerArray,
    OccupancyGrid,
    Point,
    Pose,
    Pose2D,
    Vector3,
)
from navstack.exploration import DecisionKind, ExploreParams, FrontierExplorer, GridView
from navstack.exploration.explorer import Decision
from navstack.missions.behaviours import (
    LookAround,
    MissionBehaviour,
    RememberHome,
    ReturnHome,
    WaitFor,
)
from navstack.missions.context import MissionContext
from navstack.missions.mission import Mission
from navstack.navigation import messages as m
from navstack.runtime.actions import GoalHandle, GoalStatus
from navstack.runtime.bus import LATCHED, QoS

__all__ = ["FRONTIERS_TOPIC", "Escape", "Explore", "explore_mission"]

FRONTIERS_TOPIC = "/explore/frontiers"
_BLUE = ColorRGBA(0.0, 0.0, 1.0, 1.0)
_RED = ColorRGBA(1.0, 0.0, 0.0, 1.0)
_GREY = ColorRGBA(0.5, 0.5, 0.5, 1.0)
_GREEN = ColorRGBA(0.0, 1.0, 0.0, 1.0)


class Explore(MissionBehaviour):
    """Frontier exploration until no reachable frontier is left (module docstring)."""

    def __init__(self, ctx: MissionContext, params: ExploreParams | None = None,
                 name: str = "Explore", map_timeout: float = 30.0,
                 circumscribed_radius: float = 0.3) -> None:
        super().__init__(ctx, name)
        self.params = params or ExploreParams()
        self.escape = Escape(ctx, circumscribed_radius, name=f"{name}: Escape")
        self._escaping = False
        self._pending: Decision | None = None
        self.escapes = 0
        self.map_timeout = map_timeout
        self.explorer = FrontierExplorer(self.params)
        self.handle: GoalHandle[m.NavigateToPoseGoal] | None = None
        self.decision: Decision | None = None
        self._pub = ctx.runtime.bus.publisher(FRONTIERS_TOPIC, MarkerArray, QoS(depth=1))
        self._next_plan = 0.0
        self._start = 0.0
        self._markers = 0
        # blacklist entry id -> (the entry, kept alive so its id stays its own; its points)
        self._blacklist_points: dict[int, tuple[Any, tuple[Point, ...]]] = {}
        self.done_reason = ""

    def initialise(self) -> None:
        self._start = self.ctx.now
        self._next_plan = self.ctx.now
        self._escaping = False
        self._pending = None

    def _begin_escape(self) -> None:
        """Back away from a near obstacle before the next goal (module docstring)."""
        self._escaping = True
        self.escape.initialise()

    def _escape_step(self) -> bool:
        """Run the escape; True while it is still moving the robot.  An escape that
        cannot clear the obstacle is logged, not a mission failure: the next goal (or
        the blacklist) decides."""
        before = len(self.ctx.failures)
        status = self.escape.update()
        if status is Status.RUNNING:
            return True
        if status is Status.FAILURE:
            del self.ctx.failures[before:]
            self.ctx.log(f"{self.name}: escape did not clear the obstacle; going on")
        self._escaping = False
        if self.escape.tries:
            self.escapes += 1
        return False

    # --- ticking ---------------------------------------------------------------------
    def update(self) -> Status:
        ctx, p = self.ctx, self.params
        grid = ctx.latest(p.costmap_topic, OccupancyGrid)
        now = ctx.now
        if grid is None:
            if now - self._start > self.map_timeout:
                return self.failed(f"no costmap on {p.costmap_topic} within "
                                   f"{self.map_timeout:.0f} s")
            ctx.feedback(f"{self.name}: waiting for {p.costmap_topic}")
            return Status.RUNNING
        ended = self._check_goal(now)
        if self._escaping:
            if self._escape_step():
                return Status.RUNNING
            self._next_plan = now  # plan at once from where the escape left the robot
            pending, self._pending = self._pending, None
            pose = ctx.robot_pose()
            if pending is not None and pending.target is not None and pose is not None:
                # the target chosen when the stuck goal was given up
                self._send(pending, pose)
                self._next_plan = now + 1.0 / p.planner_frequency
                return Status.RUNNING
        if now < self._next_plan and not ended:
            return Status.RUNNING
        self._next_plan = now + 1.0 / p.planner_frequency
        pose = ctx.robot_pose()
        if pose is None:
            return Status.RUNNING
        view = GridView.from_occupancy(grid, occupied_threshold=p.occupied_threshold,
                                       lethal_threshold=p.lethal_threshold)
        decision = self.explorer.plan(view, (pose.x, pose.y, pose.theta), now)
        self.decision = decision
        if decision.cancelled:
            ctx.log(f"{self.name}: gave up the goal: {decision.cancelled}")
            if decision.blacklisted or decision.kind is not DecisionKind.SEND:
                self._cancel_goal()
            if decision.blacklisted and decision.kind is not DecisionKind.DONE:
                # stuck or no progress: get clear before the next goal
                self._pending = decision if decision.kind is DecisionKind.SEND else None
                self._begin_escape()
                return Status.RUNNING
            # its frontier was observed: the next goal preempts the running one in place
            # (explore_lite's makePlan sends it without stopping the robot)
        if p.visualize and decision.frontiers is not None:
            self._publish_markers(decision, view)
        if decision.kind is DecisionKind.DONE:
            self._cancel_goal()
            self.done_reason = decision.reason
            ctx.log(f"{self.name}: exploration complete: {decision.reason}")
            return Status.SUCCESS
        if decision.kind is DecisionKind.SEND and decision.target is not None:
            self._send(decision, pose)
        self._feedback(decision, view)
        return Status.RUNNING

    def _check_goal(self, now: float) -> bool:
        """Report the current goal's end to the explorer; True if it just ended."""
        h = self.handle
        if h is None or not h.done or h.result is None:
            return False
        self.handle = None
        status = h.result.status
        if status is GoalStatus.REJECTED:
            status = GoalStatus.FAILED
        self.explorer.goal_finished(status.value, h.result.error_msg, now)
        if status is GoalStatus.FAILED:
            self.ctx.log(f"{self.name}: goal failed: {h.result.error_msg}")
            self._begin_escape()
        return True

    def _send(self, decision: Decision, pose: Pose2D) -> None:
        assert decision.target is not None
        gx, gy = decision.target.goal
        yaw = math.atan2(gy - pose.y, gx - pose.x) if math.hypot(gx - pose.x,
                                                                gy - pose.y) > 1e-6 \
            else pose.theta
        goal = m.NavigateToPoseGoal(self.ctx.pose_stamped(Pose2D(gx, gy, yaw)))
        try:
            self.handle = self.ctx.navigate_to_pose.send_goal(goal)
        except Exception as exc:  # no navigator on the bus: the goal fails like an abort
            self.handle = None
            self.explorer.goal_finished("FAILED", f"cannot send the goal: {exc}", self.ctx.now)
            return
        self.ctx.log(f"{self.name}: goal ({gx:.2f}, {gy:.2f}) for a "
                     f"{decision.target.frontier.size_m:.1f} m frontier, "
                     f"{decision.target.distance:.1f} m away ({decision.reason})")

    def _cancel_goal(self) -> None:
        if self.handle is not None and not self.handle.done:
            self.handle.cancel()
            self.ctx.stop_robot()
        self.handle = None

    def terminate(self, new_status: Status) -> None:
        if new_status is Status.INVALID:
            self._cancel_goal()
            if self._escaping:
                self.escape.terminate(Status.INVALID)
                self._escaping = False

    # --- reporting -------------------------------------------------------------------
    def _feedback(self, d: Decision, view: GridView) -> None:
        fs = d.frontiers
        n = len(fs.reachable) if fs is not None else 0
        known = float((~view.unknown).sum()) * view.resolution ** 2
        target = ""
        if d.target is not None:
            gx, gy = d.target.goal
            target = f", target ({gx:.1f}, {gy:.1f}) {d.target.distance:.1f} m away"
        self.ctx.feedback(f"{self.name}: {n} reachable frontiers{target}",
                          frontiers=n, goals=self.explorer.stats.goals_sent,
                          blacklisted=len(self.explorer.blacklist.active),
                          known_area_m2=known)

    def _publish_markers(self, d: Decision, view: GridView) -> None:
        fs = d.frontiers
        assert fs is not None
        stamp = self.ctx.now
        header = Header(stamp, self.ctx.global_frame)
        markers: list[Marker] = []

        def points(rows: Any, cols: Any) -> tuple[Point, ...]:
            pts = view.centres(rows, cols)
            return tuple(Point(x, y, 0.0) for x, y in pts.tolist())

        ident = 0
        for f, color in ([(f, _BLUE) for f in fs.reachable]
                         + [(f, _GREY) for f in fs.unreachable]):
            markers.append(Marker(header, "frontiers", ident, Marker.POINTS, Marker.ADD,
                                  Pose(), Vector3(0.1, 0.1, 0.1), color,
                                  points(f.rows, f.cols)))
            ident += 1
            if f.goal is not None:
                size = 0.25 if d.target is not None and d.target.frontier is f else 0.15
                markers.append(Marker(header, "frontiers", ident, Marker.SPHERE, Marker.ADD,
                                      Pose(Point(f.goal[0], f.goal[1], 0.0)),
                                      Vector3(size, size, size), _GREEN))
                ident += 1
        cached = self._blacklist_points
        active = self.explorer.blacklist.active
        for e in active:
            if id(e) not in cached:  # an entry's cells never change: build its points once
                cached[id(e)] = (e, tuple(Point(x, y, 0.0) for x, y in e.points.tolist()))
            pts = cached[id(e)][1]
            markers.append(Marker(header, "blacklist", ident, Marker.POINTS, Marker.ADD,
                                  Pose(), Vector3(0.1, 0.1, 0.1), _RED, pts))
            ident += 1
        # explore_lite deletes the markers it no longer uses
        markers += [Marker(header, "frontiers", k, action=Marker.DELETE)
                    for k in range(ident, self._markers)]
        self._markers = ident
        if len(cached) > len(active):
            keep = {id(e) for e in active}
            self._blacklist_points = {k: v for k, v in cached.items() if k in keep}
        self._pub.publish(MarkerArray(tuple(markers)))

    def summary(self) -> dict[str, Any]:
        st = self.explorer.stats
        last = self.explorer.last
        return {
            "strategy": self.params.strategy,
            "goals_sent": st.goals_sent, "goals_succeeded": st.goals_succeeded,
            "goals_failed": st.goals_failed, "blacklisted": st.blacklisted,
            "retries": st.retries, "plans": st.plans, "escapes": self.escapes,
            "done_reason": self.done_reason,
            "unreachable_frontiers": [
                {"centroid": list(f.centroid), "size_m": f.size_m}
                for f in (last.unreachable if last is not None else [])],
            "blacklist": self.explorer.blacklist.describe(),
            "events": [[t, text] for t, text in self.explorer.events],
        }


class Escape(MissionBehaviour):
    """Back away from an obstacle closer than the turning radius (module docstring)."""

    def __init__(self, ctx: MissionContext, circumscribed_radius: float = 0.3,
                 map_topic: str = "/map", margin: float = 0.05, attempts: int = 5,
                 name: str = "Escape", max_move: float = 1.0, required: bool = True,
                 local_costmap_topic: str | None = "/local_costmap/costmap",
                 spin_angle: float = 0.5) -> None:
        super().__init__(ctx, name)
        self.radius = circumscribed_radius
        self.map_topic = map_topic
        # the controller refuses arcs on the local costmap, whose obstacle layer marks what
        # the scans see now: a wall the SLAM map has a few centimetres off (pose error), a
        # door frame narrower than mapped.  Its lethal cells count as obstacles too (a door
        # the map says is 0.3 m clear, "collision ahead" on every arc out of it: office)
        self.local_costmap_topic = local_costmap_topic
        self.margin = margin
        self.attempts = attempts
        self.handle: GoalHandle[Any] | None = None
        self.tries = 0
        self.moved_at = -math.inf
        self.flip = False  # the last move was refused: try the other direction
        self.refused: str | None = None  # the action of the last refused move
        self.flip_refused_forward = False
        self.max_move = max_move
        self.required = required  # False: a robot that cannot get clear is logged, not failed
        self.refused_ways: set[str] = set()  # straight moves refused since the last motion
        self.spin_sign = 0.0  # the turn of the last spin tried (0: none yet)
        self.spin_angle = spin_angle

    def initialise(self) -> None:
        self.handle = None
        self.tries = 0
        self.moved_at = -math.inf
        self.flip = False
        self.refused = None
        self.flip_refused_forward = False
        self.refused_ways = set()
        self.spin_sign = 0.0

    def _nearest_obstacle(self, grid: OccupancyGrid, pose: Pose2D,
                          threshold: int = 65) -> tuple[float, float]:
        """Distance [m] and bearing (robot frame) of the nearest cell of ``grid`` at or
        above ``threshold`` (65: occupied on a map; 100: lethal on a costmap topic)."""
        info = grid.info
        data = np.asarray(grid.data).reshape(info.height, info.width)
        occ = data >= threshold
        res = info.resolution
        c0 = math.floor((pose.x - info.origin.position.x) / res)
        r0 = math.floor((pose.y - info.origin.position.y) / res)
        k = math.ceil((self.radius + 0.5) / res)
        win = occ[max(0, r0 - k):r0 + k + 1, max(0, c0 - k):c0 + k + 1]
        rr, cc = np.nonzero(win)
        if rr.size == 0:
            return math.inf, 0.0
        xs = info.origin.position.x + (cc + max(0, c0 - k) + 0.5) * res
        ys = info.origin.position.y + (rr + max(0, r0 - k) + 0.5) * res
        d = np.hypot(xs - pose.x, ys - pose.y) - res / 2
        i = int(np.argmin(d))
        bearing = math.atan2(ys[i] - pose.y, xs[i] - pose.x) - pose.theta
        return float(d[i]), math.atan2(math.sin(bearing), math.cos(bearing))

    def _local_layers(self) -> list[tuple[OccupancyGrid, Pose2D]]:
        """The local costmap and the robot's pose in its frame ([] when there is none)."""
        if self.local_costmap_topic is None:
            return []
        grid = self.ctx.latest(self.local_costmap_topic, OccupancyGrid)
        if grid is None:
            return []
        pose = self.ctx.pose_in(grid.header.frame_id)
        return [] if pose is None else [(grid, pose)]

    def _nearest_all(self, grid: OccupancyGrid, pose: Pose2D,
                     local: Seq[tuple[OccupancyGrid, Pose2D]], ahead: float = 0.0
                     ) -> tuple[float, float]:
        """The nearest obstacle over the map and the local costmaps' lethal cells, with
        the robot moved ``ahead`` [m] along its heading (negative: back)."""

        def moved(p: Pose2D) -> Pose2D:
            return Pose2D(p.x + ahead * math.cos(p.theta), p.y + ahead * math.sin(p.theta),
                          p.theta)

        best = self._nearest_obstacle(grid, moved(pose))
        for g, p in local:
            here = self._nearest_obstacle(g, moved(p), threshold=100)
            if here[0] < best[0]:
                best = here
        return best

    def _choose_move(self, grid: OccupancyGrid, pose: Pose2D, dist: float,
                     bearing: float, local: Seq[tuple[OccupancyGrid, Pose2D]] = ()
                     ) -> tuple[bool, float]:
        """``(forward, distance)`` of the straight move that escapes: the shortest one,
        forward or back, whose end pose is ``radius`` clear of the map's obstacles and
        that never comes closer to one than the robot is now (a box beside the robot:
        drive along it until past its end); failing that, the one whose end is
        clearest.  A direction the behaviour server refused is tried last."""
        best: tuple[float, bool, float] | None = None  # (clearance, forward, distance)
        found: tuple[float, bool, float] | None = None  # (distance, forward, distance)
        for forward in (False, True):
            if forward == self.flip_refused_forward and self.refused is not None:
                continue
            sign = 1.0 if forward else -1.0
            for k in range(1, round(self.max_move / 0.05) + 1):
                d = 0.05 * k
                clear, _ = self._nearest_all(grid, pose, local, sign * d)
                if clear < dist - 0.02:
                    break  # this way runs into something
                if d >= 0.1 and (best is None or clear > best[0] + 1e-9):
                    best = (clear, forward, d)
                if clear >= self.radius:
                    if found is None or d < found[0]:
                        found = (d, forward, d)
                    break
        if found is not None:
            return found[1], found[2] + self.margin
        if best is not None and best[0] > dist + 0.02:
            return best[1], best[2] + self.margin
        # nothing measurably better on the map: away from the nearest obstacle, then the
        # other way once a move was refused
        along = abs(math.cos(bearing))
        distance = max(0.1, (self.radius - dist) / max(along, 0.5) + self.margin)
        return (abs(bearing) >= math.pi / 2) != self.flip, distance

    def update(self) -> Status:
        ctx = self.ctx
        h = self.handle
        if h is not None:
            if not h.done:
                return Status.RUNNING
            self.handle = None
            self.moved_at = ctx.now
            if h.result is not None and h.result.status is not GoalStatus.SUCCEEDED:
                ctx.log(f"{self.name}: {h.action} ended {h.result.status.value}: "
                        f"{h.result.error_msg}")
                if h.action.endswith("spin"):
                    self.spin_sign = -self.spin_sign  # the other turn next
                    self.refused_ways.add(h.action)
                else:
                    self.flip = not self.flip  # that way is blocked: the other way next
                    self.refused = h.action
                    self.flip_refused_forward = h.action.endswith("drive_on_heading")
                    self.refused_ways.add("forward" if self.flip_refused_forward else "back")
            else:
                self.refused = None  # it moved: both ways are open again
                self.refused_ways = set()
        grid = ctx.latest(self.map_topic, OccupancyGrid, LATCHED)
        pose = ctx.robot_pose()
        if grid is None or pose is None:
            return Status.RUNNING
        if grid.header.stamp < self.moved_at:  # judge on a map made after the move
            return Status.RUNNING
        local = self._local_layers()
        if any(g.header.stamp < self.moved_at for g, _ in local):
            return Status.RUNNING
        dist, bearing = self._nearest_all(grid, pose, local)
        if dist >= self.radius:
            return Status.SUCCESS
        if self.tries >= self.attempts:
            reason = (f"still {dist:.2f} m from an obstacle after {self.tries} attempts to "
                      f"back away (needs {self.radius:.2f} m to turn)")
            if not self.required:  # e.g. in a gap narrower than two turning radii
                ctx.log(f"{self.name}: {reason}; going on")
                return Status.SUCCESS
            return self.failed(reason)
        self.tries += 1
        if {"forward", "back"} <= self.refused_ways:
            # wedged: obstacles ahead and behind (a turn in place ended between two
            # obstacles, office).  Turn away from the nearest one -- the behaviour server
            # refuses a turn that would hit anything -- and try straight moves after it
            if self.spin_sign == 0.0:
                self.spin_sign = -1.0 if bearing > 0.0 else 1.0
            angle = self.spin_sign * self.spin_angle
            self.refused_ways.discard("forward")
            self.refused_ways.discard("back")
            self.refused = None
            ctx.log(f"{self.name}: obstacle {dist:.2f} m away at bearing "
                    f"{math.degrees(bearing):.0f} deg and both straight moves refused: "
                    f"turning {math.degrees(angle):.0f} deg")
            ctx.feedback(f"{self.name}: turning {math.degrees(angle):.0f} deg")
            self.handle = ctx.spin.send_goal(m.SpinGoal(angle, 10.0))
            return Status.RUNNING
        forward, distance = self._choose_move(grid, pose, dist, bearing, local)
        if not forward:
            goal: Any = m.BackUpGoal(distance, 0.1, 10.0)
            client: Any = ctx.backup
            how = "backing up"
        else:
            goal = m.DriveOnHeadingGoal(distance, 0.1, 10.0)
            client = ctx.drive_on_heading
            how = "driving forward"
        ctx.log(f"{self.name}: obstacle {dist:.2f} m away at bearing "
                f"{math.degrees(bearing):.0f} deg, closer than the turning radius "
                f"{self.radius:.2f} m: {how} {distance:.2f} m")
        ctx.feedback(f"{self.name}: {how} {distance:.2f} m")
        self.handle = client.send_goal(goal)
        return Status.RUNNING

    def terminate(self, new_status: Status) -> None:
        if new_status is Status.INVALID and self.handle is not None and not self.handle.done:
            self.handle.cancel()


def wait_for_map(ctx: MissionContext, topic: str = "/map", settle: float = 0.5,
                 timeout: float = 30.0) -> WaitFor:
    """Wait for the first map and then ``settle`` seconds: SLAM's ``map -> odom`` is right
    only once its first scan is placed (before that slam nodes publish a guess, future-dated
    by ``transform_timeout``), so the home pose is read after it."""
    first: list[float] = []

    def ready() -> bool:
        grid = ctx.latest(topic, OccupancyGrid, LATCHED)
        if grid is None:
            return False
        if not first:
            first.append(ctx.now)
        return ctx.now - first[0] >= settle

    return WaitFor(ctx, ready, timeout, f"the first map on {topic}", name="WaitForMap")


def explore_mission(ctx: MissionContext, params: ExploreParams | None = None,
                    circumscribed_radius: float = 0.3,
                    home_tolerance: float = 0.3) -> Mission:
    """explore_lite as a mission (module docstring)."""
    p = params or ExploreParams()
    if p.goal_clearance is None:  # goals where this robot can turn round
        p = p.updated(goal_clearance=circumscribed_radius)
    explore = Explore(ctx, p, circumscribed_radius=circumscribed_radius)
    steps = [wait_for_map(ctx), RememberHome(ctx),
             Escape(ctx, circumscribed_radius),
             explore]
    if p.return_to_init:
        # best effort: where no spot is a turning radius clear (a 0.6 m gap) the way home
        # may still be open -- ReturnHome decides
        steps += [Escape(ctx, circumscribed_radius, name="EscapeBeforeHome", required=False),
                  ReturnHome(ctx, tolerance=home_tolerance,
                             between=Escape(ctx, circumscribed_radius, name="EscapeBeforeRetry",
                                            required=False),
                             relocalise=LookAround(ctx, name="LookAroundAtHome")
                             if p.look_around_at_home else None)]
    root = Sequence("explore", memory=True, children=steps)

    def summary() -> dict[str, Any]:
        out = {"explore": explore.summary()}
        if "home_distance" in ctx.results:
            out["home_distance_estimate_m"] = ctx.results["home_distance"]
        return out

    return Mission("explore", root, ctx, "frontier exploration, then return home", summary)
