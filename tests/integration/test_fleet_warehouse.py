"""Issue 21, acceptance 4: three robots in the warehouse, one namespace and one route
each, all on one clock: every goal succeeds, 0 collisions (robot-robot included), and
taps on every namespace show no message crossing from one robot to another."""

from __future__ import annotations

import math
from collections import defaultdict
from typing import Any

import pytest
import yaml

from navstack.core.errors import ConfigError
from navstack.core.msgs import Odometry, Path, Twist
from navstack.interfaces.fleet import Fleet, FleetParams, load_fleet
from navstack.interfaces.fleet_mission import FleetMission
from navstack.interfaces.stack import default_nav2_params_path

PLANNER_TOLERANCE = yaml.safe_load(default_nav2_params_path().read_text())[
    "planner_server"]["ros__parameters"]["GridBased"]["tolerance"]


class Taps:
    """Every message of every namespace, as the fleet tap reports it."""

    def __init__(self, fleet: Fleet) -> None:
        self.by_ns: dict[str, dict[str, list[Any]]] = defaultdict(lambda: defaultdict(list))
        self.owner: dict[int, str] = {}
        self.shared: list[tuple[str, str]] = []
        self.bad_names: list[str] = []
        self.names = fleet.names
        fleet.add_tap(self.tap)

    def tap(self, topic: str, msg: Any, _t: float) -> None:
        ns, _, rest = topic[1:].partition("/")
        if ns not in self.names or not rest:
            self.bad_names.append(topic)
            return
        self.by_ns[ns]["/" + rest].append(msg)
        seen = self.owner.setdefault(id(msg), ns)
        if seen != ns:  # one message object published in two namespaces
            self.shared.append((seen, topic))


@pytest.fixture(scope="module")
def run():
    fleet = Fleet(load_fleet(), robots=3).start()
    taps = Taps(fleet)
    commands: dict[str, list[tuple[float, float]]] = {n: [] for n in fleet.names}
    for name in fleet.names:  # what each simulated base actually receives
        sim = fleet.physics.sim(name)
        original = sim.set_command

        def accept(cmd, now, _orig=original, _log=commands[name]):
            _log.append((cmd.vx, cmd.wz))
            return _orig(cmd, now)
        sim.set_command = accept  # type: ignore[method-assign]
    mission = FleetMission(fleet)
    truth_gap = dict.fromkeys(fleet.names, 0.0)
    while not mission.done and fleet.now < 400.0:
        mission.step()
        for name in fleet.names:  # each namespace's ground truth is its own robot's
            last = taps.by_ns[name]["/ground_truth"][-1]
            p = fleet.physics.sim(name).pose
            q = last.pose.pose.position
            truth_gap[name] = max(truth_gap[name], math.hypot(q.x - p.x, q.y - p.y))
    return fleet, mission, taps, commands, truth_gap, mission.report(1.0)


def test_every_robot_reaches_every_goal_without_touching_anything(run):
    _, _, _, _, _, report = run
    assert [r["name"] for r in report["robots"]] == ["robot1", "robot2", "robot3"]
    for r in report["robots"]:
        assert [g["status"] for g in r["goals"]] == ["SUCCEEDED"] * len(r["goals"]), r
        assert r["collisions"] == 0 and r["robot_collisions"] == 0
    assert report["success"] is True
    assert report["collisions"] == 0 and report["robot_robot_collisions"] == 0
    # the routes cross: the robots met, and never touched (exact body distance)
    assert 0.0 < report["min_robot_distance_m"] < 1.0


def test_no_message_crosses_namespaces(run):
    fleet, _, taps, commands, truth_gap, _ = run
    assert taps.bad_names == []
    assert taps.shared == []
    topics = {ns: set(t) for ns, t in taps.by_ns.items()}
    assert set(topics) == set(fleet.names)
    # the same stack in every namespace, with names relative to it (no robot's name)
    core = {"/scan", "/odom", "/tf", "/cmd_vel", "/plan",
            "/ground_truth", "/local_costmap/costmap", "/global_costmap/costmap"}
    for name in fleet.names:
        assert core <= topics[name]
        assert not any(n in t for t in topics[name] for n in fleet.names)
    for name in fleet.names:
        # ground truth of namespace robotN is robot N's pose (the robots are metres apart)
        assert truth_gap[name] < 0.05
        # every command robot N's base accepted was published on /robotN/cmd_vel, in order
        published = [(m.linear.x, m.angular.z) for m in taps.by_ns[name]["/cmd_vel"]
                     if isinstance(m, Twist)]
        accepted = commands[name]
        assert accepted and _is_subsequence(accepted, published)
        # every plan in namespace robotN ends at one of robot N's own goals: on it, or --
        # when another robot stands by it (its padded disc covers the goal) -- at the
        # nearest free cell within NavFn's tolerance, still nearer than any other robot's
        goals = [g.pose[:2] for g in fleet.members[fleet.names.index(name)].route]
        foreign = [g.pose[:2] for i, m in enumerate(fleet.members) if fleet.names[i] != name
                   for g in m.route]
        for plan in taps.by_ns[name]["/plan"]:
            assert isinstance(plan, Path)
            end = plan.as_array()[-1]
            own = min(math.hypot(end[0] - gx, end[1] - gy) for gx, gy in goals)
            assert own <= PLANNER_TOLERANCE
            assert own < min(math.hypot(end[0] - gx, end[1] - gy) for gx, gy in foreign)
        odom = taps.by_ns[name]["/odom"]
        assert odom and all(isinstance(m, Odometry) for m in odom)


def _is_subsequence(short: list[Any], long: list[Any]) -> bool:
    it = iter(long)
    return all(any(x == y for y in it) for x in short)


def test_fleet_file_errors_name_the_key():
    good = load_fleet().model_dump()
    bad = {**good, "robots": [{**good["robots"][0], "name": "robot 1"}]}
    with pytest.raises(ConfigError, match=r"robots\[0\]\.name.*not a ROS namespace"):
        FleetParams.from_mapping(bad)
    with pytest.raises(ConfigError, match="--robots 4: the fleet 'warehouse_fleet' defines 3"):
        Fleet(load_fleet(), robots=4)
