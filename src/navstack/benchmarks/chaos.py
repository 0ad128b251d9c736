"""The chaos suite: deterministic navigation scenarios with injected faults.

:func:`chaos_scenarios` draws ``count`` start/goal trips over the built-in worlds from
one seed and gives each a :class:`Fault` (or none), cycling through :data:`FAULT_KINDS`:

* ``lidar_dropout`` -- single beams lost (``+inf``) and whole scans not published
  (``LidarParams.dropout_prob`` / ``scan_dropout_prob`` = ``level``);
* ``odom_slip`` -- the wheels slip with probability ``level`` per odometry period
  (``OdometryParams.slip_prob``; the odometry frame drifts from the truth);
* ``scan_latency`` -- every ``/scan`` reaches the stack ``level`` seconds after it was
  measured (stamped at measurement time, as a driver behind a slow link);
* ``tf_delay`` -- the simulator's ``/tf`` (``odom -> base_link`` and the perfect
  ``map -> odom``) arrives ``level`` seconds late;
* ``kidnap`` -- at ``at_s`` the robot is carried ``level`` metres to a free spot
  (localization follows: the stack must replan from where it is);
* ``blocked`` -- an obstacle that is not on the map stands on the shortest route; a
  detour exists (checked when the scenario is drawn);
* ``crowd`` -- ``level`` extra people walk back and forth across the route.

Clock offset and link blackout need the robot / base split over a transport (issue 21,
items 2-3); a single-process scenario has one clock and no link, so they are not drawn
here.  Everything is a pure function of the seed: a scenario runs identically in any
process, which is what lets :mod:`navstack.benchmarks.sweep` farm them out.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from scipy import ndimage

from navstack.core.errors import ConfigError
from navstack.core.msgs import Pose2D
from navstack.navigation.trees import NavigateTreeParams
from navstack.sim.robot import RobotParams
from navstack.sim.world import MovingObstacle, World
from navstack.sim.worlds import load_world

FAULT_KINDS: tuple[str, ...] = ("lidar_dropout", "odom_slip", "scan_latency", "tf_delay",
                                "kidnap", "blocked", "crowd")
"""Fault variants of the chaos suite, in the order scenarios cycle through them."""

#: worlds trips are drawn in, with the minimum start-goal distance [m] in each
CHAOS_WORLDS: tuple[tuple[str, float], ...] = (("office", 3.0), ("warehouse", 3.0),
                                               ("maze", 2.5))
#: clearance [m] of drawn start/goal poses, people's paths and the blocked detour
CLEARANCE_M = 0.55
ROBOT_CLEARANCE_M = 0.3


def navigator_give_up_s(tree: NavigateTreeParams | None = None) -> float:
    """How long [s] the default NavigateToPose tree keeps the goal of a robot that
    makes no progress at all before it fails the goal itself: each of its
    ``number_of_retries + 1`` rounds runs FollowPath until the progress guard fires
    (``progress_dwell_time``), clears the local costmap and runs it once more, and
    between rounds one recovery runs (at most ``behavior_time_allowance`` or
    ``wait_duration``).  200 s with the defaults."""
    t = tree or NavigateTreeParams()
    rounds = t.number_of_retries + 1
    return (2 * rounds * t.progress_dwell_time
            + t.number_of_retries * max(t.behavior_time_allowance, t.wait_duration))


def trip_timeout_s(dist: float) -> float:
    """The benchmark's time limit [s] for a trip of ``dist`` metres: the navigator's own
    give-up time (:func:`navigator_give_up_s`) and 20 s for planning, plus 10 s per
    metre of travel.  Shorter limits stopped stuck goals a few seconds before the
    navigator would have failed them with its reason (chaos_0740, 0815: 157 s, 177 s
    against limits of 148 s and 174 s)."""
    return navigator_give_up_s() + 20.0 + 10.0 * dist


@dataclass(frozen=True)
class Fault:
    """One injected fault (see the module docstring for what ``level`` means per kind).

    ``box`` is the unmapped obstacle of ``blocked`` (x0, y0, x1, y1); ``walkers`` the
    people of ``crowd`` as (x0, y0, x1, y1, speed) back-and-forth lines.
    """

    kind: str
    level: float = 0.0
    at_s: float = 0.0
    box: tuple[float, float, float, float] | None = None
    walkers: tuple[tuple[float, float, float, float, float], ...] = ()

    def __post_init__(self) -> None:
        if self.kind not in FAULT_KINDS:
            raise ConfigError(f"unknown fault '{self.kind}'", key_path="faults",
                              suggestion="one of " + ", ".join(FAULT_KINDS))

    def label(self) -> str:
        return f"{self.kind}({self.level:g})"


def parse_faults(text: str) -> tuple[str, ...]:
    """``--faults``: ``all``, ``none`` or a comma list of :data:`FAULT_KINDS`."""
    text = text.strip().lower()
    if text in ("", "all"):
        return FAULT_KINDS
    if text == "none":
        return ()
    kinds = tuple(k.strip() for k in text.split(",") if k.strip())
    for kind in kinds:
        if kind not in FAULT_KINDS:
            raise ConfigError(f"unknown fault '{kind}'", key_path="--faults",
                              suggestion="all, none or a comma list of "
                                         + ", ".join(FAULT_KINDS))
    return kinds


# --- drawing ---------------------------------------------------------------------------
def _region(world: World, clearance: float) -> np.ndarray:
    """Cells with ``clearance`` to obstacles in the largest connected free region."""
    free = world.distance_field() >= clearance
    labels, n = ndimage.label(free)
    if n == 0:
        return np.zeros_like(free)
    sizes = np.bincount(labels.ravel())[1:]
    return np.asarray(labels == (1 + int(np.argmax(sizes))))


def _route(free: np.ndarray, start: tuple[int, int], goal: tuple[int, int]
           ) -> list[tuple[int, int]] | None:
    """Shortest 8-connected cell route (row, col) over ``free``, or None if cut off."""
    dist = np.full(free.shape, -1, dtype=np.int64)
    dist[goal] = 0
    frontier = [goal]
    h, w = free.shape
    steps = ((-1, 0), (1, 0), (0, -1), (0, 1), (-1, -1), (-1, 1), (1, -1), (1, 1))
    while frontier and dist[start] < 0:
        nxt = []
        for r, c in frontier:
            d = dist[r, c] + 1
            for dr, dc in steps:
                rr, cc = r + dr, c + dc
                if 0 <= rr < h and 0 <= cc < w and free[rr, cc] and dist[rr, cc] < 0:
                    dist[rr, cc] = d
                    nxt.append((rr, cc))
        frontier = nxt
    if dist[start] < 0:
        return None
    path = [start]
    while path[-1] != goal:
        r, c = path[-1]
        best = min(((r + dr, c + dc) for dr, dc in steps
                    if 0 <= r + dr < h and 0 <= c + dc < w and dist[r + dr, c + dc] >= 0),
                   key=lambda rc: int(dist[rc]))
        path.append(best)
    return path


def _box_cells(world: World, box: tuple[float, float, float, float]) -> tuple[slice, slice]:
    x0, y0, x1, y1 = box
    c0 = max(int((x0 - world.origin_x) / world.resolution), 0)
    c1 = math.ceil((x1 - world.origin_x) / world.resolution)
    r0 = max(int((y0 - world.origin_y) / world.resolution), 0)
    r1 = math.ceil((y1 - world.origin_y) / world.resolution)
    return slice(r0, r1), slice(c0, c1)


def _blocked_fault(world: World, start: Pose2D, goal: Pose2D) -> Fault | None:
    """A 0.6 m box on the shortest route whose detour keeps ``CLEARANCE_M``, or None."""
    free = _region(world, ROBOT_CLEARANCE_M)
    s, g = world.world_to_cell(start.x, start.y), world.world_to_cell(goal.x, goal.y)
    route = _route(free, s, g)
    if route is None or len(route) < 20:
        return None
    for frac in (0.5, 0.4, 0.6, 0.3, 0.7):
        r, c = route[int(frac * (len(route) - 1))]
        x, y = world.cell_center(r, c)
        box = (x - 0.3, y - 0.3, x + 0.3, y + 0.3)
        if math.hypot(x - start.x, y - start.y) < 1.5 or math.hypot(x - goal.x, y - goal.y) < 1.5:
            continue
        occ = world.occupied.copy()
        occ[_box_cells(world, box)] = True
        blocked = replace(world, occupied=occ)
        if _route(_region_all(blocked, CLEARANCE_M), s, g) is not None:
            return Fault("blocked", 0.6, box=box)
    return None


def _region_all(world: World, clearance: float) -> np.ndarray:
    return np.asarray(world.distance_field() >= clearance)


def _crowd_fault(world: World, start: Pose2D, goal: Pose2D, rng: np.random.Generator,
                 people: int) -> Fault | None:
    """``people`` walkers crossing the start-goal line, clear of start and goal."""
    free = _region(world, CLEARANCE_M)
    walkers: list[tuple[float, float, float, float, float]] = []
    for _ in range(60 * people):
        if len(walkers) == people:
            break
        f = float(rng.uniform(0.3, 0.7))
        mx, my = start.x + f * (goal.x - start.x), start.y + f * (goal.y - start.y)
        ang = float(rng.uniform(-math.pi, math.pi))
        half = float(rng.uniform(1.0, 2.5))
        a = (mx - half * math.cos(ang), my - half * math.sin(ang))
        b = (mx + half * math.cos(ang), my + half * math.sin(ang))
        pts = np.linspace(a, b, 20)
        ok = True
        for px, py in pts:
            if not world.in_bounds(px, py):
                ok = False
                break
            r, c = world.world_to_cell(px, py)
            if not free[r, c] or min(math.hypot(px - start.x, py - start.y),
                                     math.hypot(px - goal.x, py - goal.y)) < 1.2:
                ok = False
                break
        if ok:
            walkers.append((a[0], a[1], b[0], b[1], float(rng.uniform(0.3, 0.6))))
    return Fault("crowd", float(len(walkers)), walkers=tuple(walkers)) if walkers else None


def _kidnap_fault(world: World, start: Pose2D, goal: Pose2D,
                  rng: np.random.Generator) -> Fault | None:
    """Carry the robot about 1 m sideways after a few seconds, onto a clear cell."""
    free = _region(world, CLEARANCE_M)
    at_s = float(rng.uniform(3.0, 6.0))
    return Fault("kidnap", float(rng.uniform(0.6, 1.2)), at_s=at_s) if free.any() else None


def draw_fault(kind: str, world: World, start: Pose2D, goal: Pose2D,
               rng: np.random.Generator) -> Fault | None:
    """A fault of ``kind`` for this trip (None when the trip cannot host it)."""
    if kind == "lidar_dropout":
        return Fault(kind, float(rng.choice([0.05, 0.1, 0.2])))
    if kind == "odom_slip":
        return Fault(kind, float(rng.choice([0.01, 0.02, 0.05])))
    if kind == "scan_latency":
        return Fault(kind, float(rng.choice([0.05, 0.1, 0.2])))
    if kind == "tf_delay":
        return Fault(kind, float(rng.choice([0.02, 0.05, 0.1])))
    if kind == "kidnap":
        return _kidnap_fault(world, start, goal, rng)
    if kind == "blocked":
        return _blocked_fault(world, start, goal)
    return _crowd_fault(world, start, goal, rng, int(rng.integers(2, 5)))


def chaos_trips(count: int, seed: int, faults: tuple[str, ...]
                ) -> list[tuple[str, str, Pose2D, Pose2D, Fault | None, float]]:
    """``count`` trips ``(name, world, start, goal, fault, timeout_s)``; every
    ``len(faults) + 1``-th trip has no fault (the nominal control group)."""
    rng = np.random.default_rng(seed)
    worlds = {name: load_world(name) for name, _ in CHAOS_WORLDS}
    cells = {name: np.argwhere(_region(worlds[name], CLEARANCE_M)) for name in worlds}
    cycle: tuple[str | None, ...] = (None, *faults)
    out: list[tuple[str, str, Pose2D, Pose2D, Fault | None, float]] = []
    while len(out) < count:
        i = len(out)
        wname, min_dist = CHAOS_WORLDS[i % len(CHAOS_WORLDS)]
        world, free = worlds[wname], cells[wname]
        a, b = free[rng.integers(len(free), size=2)]
        sx, sy = world.cell_center(int(a[0]), int(a[1]))
        gx, gy = world.cell_center(int(b[0]), int(b[1]))
        dist = math.hypot(gx - sx, gy - sy)
        if dist < min_dist or dist > 14.0:
            continue
        start = Pose2D(sx, sy, float(rng.uniform(-math.pi, math.pi)))
        goal = Pose2D(gx, gy, float(rng.uniform(-math.pi, math.pi)))
        kind = cycle[(i // len(CHAOS_WORLDS)) % len(cycle)]
        fault = draw_fault(kind, world, start, goal, rng) if kind is not None else None
        if kind is not None and fault is None:
            continue  # this trip cannot host the fault: draw another
        if not _start_clear_of_movers(world_with_fault(world, fault), start):
            continue  # a walker or vehicle stands on the start at t = 0: draw another
        tag = fault.kind if fault is not None else "nominal"
        out.append((f"chaos_{i:04d}_{wname}_{tag}", wname, start, goal, fault,
                    trip_timeout_s(dist)))
    return out


def _start_clear_of_movers(world: World, start: Pose2D) -> bool:
    """Whether every moving obstacle is at least ``CLEARANCE_M`` beyond its own extent
    from ``start`` at ``t = 0``.  A trip that starts with a walker or the forklift already
    touching the robot scores a collision no navigation could avoid (four of the
    1000-trip seed-7 draw did)."""
    for mover in world.moving_obstacles:
        x, y, _ = mover.pose_at(0.0)
        extent = mover.radius if mover.shape == "circle" else 0.5 * math.hypot(*mover.size)
        if math.hypot(x - start.x, y - start.y) < extent + CLEARANCE_M:
            return False
    return True


# --- applying ----------------------------------------------------------------------------
def world_with_fault(world: World, fault: Fault | None) -> World:
    """The simulated world with the fault's unmapped obstacle or extra people."""
    if fault is None:
        return world
    if fault.kind == "blocked" and fault.box is not None:
        occ = world.occupied.copy()
        occ[_box_cells(world, fault.box)] = True
        return replace(world, occupied=occ)
    if fault.kind == "crowd" and fault.walkers:
        people = tuple(MovingObstacle(f"chaos_person_{k}", "circle",
                                      np.array([[x0, y0], [x1, y1]]), speed, radius=0.25)
                       for k, (x0, y0, x1, y1, speed) in enumerate(fault.walkers))
        return replace(world, moving_obstacles=(*world.moving_obstacles, *people))
    return world


def robot_with_fault(robot: RobotParams, fault: Fault | None) -> RobotParams:
    """The robot profile with the fault's sensor imperfection."""
    if fault is None:
        return robot
    sensors = robot.sensors
    if fault.kind == "lidar_dropout":
        lidar = sensors.lidar.model_copy(update={"dropout_prob": fault.level,
                                                 "scan_dropout_prob": fault.level})
        return robot.model_copy(update={"sensors": sensors.model_copy(update={"lidar": lidar})})
    if fault.kind == "odom_slip":
        odom = sensors.odometry.model_copy(update={"slip_prob": fault.level})
        return robot.model_copy(update={"sensors": sensors.model_copy(
            update={"odometry": odom})})
    return robot


class DelayedPublisher:
    """Stands in for a publisher: each message is published ``delay`` seconds later
    (simulated time), unchanged (its stamp is the measurement time)."""

    def __init__(self, publisher: Any, schedule: Callable[..., Any], delay: float) -> None:
        self._publisher = publisher
        self._schedule = schedule
        self.delay = delay

    def publish(self, msg: Any) -> None:
        self._schedule(self.delay, self._publisher.publish, msg)

    def __getattr__(self, name: str) -> Any:
        return getattr(self._publisher, name)


def attach_fault(stack: Any, fault: Fault | None) -> list[str]:
    """Install the run-time part of ``fault`` on a started :class:`NavStack`.

    Returns a list the fault writes what it did into (e.g. where a kidnapping put the
    robot), for the scenario's outcome.
    """
    events: list[str] = []
    if fault is None:
        return events
    sim_node = stack.sim
    later = stack.runtime.scheduler.call_later
    if fault.kind == "scan_latency":
        sim_node.pub_scan = DelayedPublisher(sim_node.pub_scan, later, fault.level)
    elif fault.kind == "tf_delay":
        sim_node.pub_tf = DelayedPublisher(sim_node.pub_tf, later, fault.level)
    elif fault.kind == "kidnap":
        stack.runtime.scheduler.call_at(stack.now + fault.at_s, _kidnap, stack, fault.level,
                                        events)
    return events


def _kidnap(stack: Any, distance: float, events: list[str]) -> None:
    """Teleport the robot ``distance`` m (or less) to a spot clear of walls and people,
    trying left, right, then the other directions; notes where it went in ``events``."""
    sim = stack.sim.sim
    world: World = sim.world
    stack.sim.advance()
    pose = sim.pose
    df = world.distance_field()
    clocks = sim.obstacle_clocks
    for scale in (1.0, 0.75, 0.5):
        for k in (2, 6, 1, 3, 5, 7, 0, 4):  # multiples of 45 deg from the heading
            ang = pose.theta + k * math.pi / 4
            d = distance * scale
            x, y = pose.x + d * math.cos(ang), pose.y + d * math.sin(ang)
            if not world.in_bounds(x, y):
                continue
            r, c = world.world_to_cell(x, y)
            ring = [(x + 0.6 * math.cos(j * math.pi / 4), y + 0.6 * math.sin(j * math.pi / 4))
                    for j in range(8)]
            if df[r, c] >= CLEARANCE_M and all(world.is_free(px, py, clocks)
                                               for px, py in [(x, y), *ring]):
                sim.teleport(Pose2D(x, y, pose.theta))
                events.append(f"kidnapped {d:.2f} m at t={stack.now:.1f} s from "
                              f"({pose.x:.2f}, {pose.y:.2f}) to ({x:.2f}, {y:.2f})")
                return
    events.append(f"kidnap at t={stack.now:.1f} s skipped: no clear spot within "
                  f"{distance:.2f} m of ({pose.x:.2f}, {pose.y:.2f})")
