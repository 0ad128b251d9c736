"""Health checks: small functions ``(Observations, HealthParams) -> CheckResult``.

Each check measures one contract of the navigation pipeline (ARCHITECTURE.md §2-3) and,
when it fails, says what it measured and how to fix it.  A check that cannot be judged
from what was observed (no goal yet, a bag without lifecycle states) passes with a
``detail`` starting ``"not judged:"`` so a table stays honest about it.

Names (``CheckResult.name``) are stable identifiers: the doctor's contracts reuse them.
"""

from __future__ import annotations

import math
from itertools import pairwise

import numpy as np

from navstack.core.tf_checks import check_chain
from navstack.interfaces.health.analysis import (
    follow_stats,
    inside,
    progress_trip,
    tf_staleness,
    total_length,
)
from navstack.interfaces.health.model import CheckResult, HealthParams, Observations
from navstack.navigation.messages import ControllerErrorCode

_PUBLISHERS = {
    "/scan": "the lidar driver (simulator)", "/odom": "the base's odometry (simulator)",
    "/tf": "odometry and localization", "/cmd_vel": "the controller via the collision monitor",
}


def _recent(obs: Observations, params: HealthParams) -> tuple[float, float]:
    return max(obs.start, obs.now - params.window), obs.now


def topic_rate(obs: Observations, params: HealthParams, topic: str) -> CheckResult:
    """``topic`` delivered at least ``(1 - rate_tolerance)`` of its expected rate over
    the last ``window`` seconds."""
    name = f"rate:{topic}"
    expected = obs.expected_rates.get(topic)
    lo, hi = _recent(obs, params)
    times = obs.topic_times.get(topic, np.zeros(0))
    n = int(np.count_nonzero((times > lo) & (times <= hi)))
    span = hi - lo
    if expected is None or span <= 0:
        return CheckResult(name, True, f"not judged: {n} messages, no expected rate known")
    rate = n / span
    need = (1.0 - params.rate_tolerance) * expected
    detail = f"{rate:.1f} Hz over the last {span:.1f} s (expected {expected:.1f} Hz)"
    if rate + 1e-9 >= need:
        return CheckResult(name, True, detail)
    who = _PUBLISHERS.get(topic, "its publisher")
    return CheckResult(name, False, detail + ("; nothing published" if n == 0 else ""),
                       f"check that {who} is running and publishes {topic}")


def cmd_vel_published(obs: Observations, params: HealthParams,
                      since: float | None = None) -> CheckResult:
    """``/cmd_vel`` flows at the controller's rate while a navigation goal is active
    (judged over the goals inside ``[since, now]``, default the last ``window``)."""
    name = "cmd_vel_published"
    lo = _recent(obs, params)[0] if since is None else since
    intervals = [(max(a, lo), b) for a, b in obs.goal_intervals() if b > lo]
    span = total_length(intervals)
    if span < 0.5:
        return CheckResult(name, True, "not judged: no goal was active long enough "
                                       "(0.5 s) in the span")
    times = obs.topic_times.get("/cmd_vel", np.zeros(0))
    n = int(np.count_nonzero(inside(times, intervals)))
    rate = n / span
    expected = obs.expected_rates.get("/cmd_vel")
    detail = f"{n} /cmd_vel messages in {span:.1f} s of active goal ({rate:.1f} Hz"
    detail += f", expected {expected:.1f} Hz)" if expected else ")"
    ok = rate + 1e-9 >= (1.0 - params.rate_tolerance) * expected if expected else n > 0
    return CheckResult(name, ok, detail, "" if ok else
                       "follow the chain controller_server -> /cmd_vel_nav -> "
                       "velocity_smoother -> collision_monitor (stale source? state on "
                       "/collision_monitor_state) -> twist_mux (locked?) -> /cmd_vel "
                       "(see the doctor)")


def map_latched(obs: Observations, params: HealthParams) -> CheckResult:
    """``/map`` is held by a latched (transient-local) publisher."""
    name = "map_latched"
    if "/map" not in obs.latched:
        return CheckResult(name, True, "not judged: this stack has no /map publisher")
    if obs.latched["/map"]:
        return CheckResult(name, True, "/map is latched (late subscribers receive it)")
    return CheckResult(name, False, "/map has no latched message",
                       "publish /map with a latched (transient local) QoS: map_server or "
                       "SLAM must be active")


def tf_chain(obs: Observations, params: HealthParams) -> CheckResult:
    """``map -> odom -> base_link -> sensor`` resolves and every dynamic edge's newest
    sample is younger than ``transform_tolerance``."""
    name = "tf"
    chain = [obs.global_frame, obs.odom_frame, obs.base_frame]
    if obs.global_frame == obs.odom_frame:  # odometry-only navigation
        chain = chain[1:]
    problems: list[str] = []
    for sensor in obs.sensor_frames or ("",):
        frames = [*chain, sensor] if sensor else chain
        problems += [p for p in check_chain(obs.tf, frames, None) if p not in problems]
    worst: list[str] = []
    for parent, child in pairwise(chain):
        age, at, newest = _edge_age(obs, parent, child)
        if age > params.transform_tolerance:
            seen = "never received" if math.isinf(age) else (
                f"{age:.2f} s old at t={at:.2f} s (newest stamp {newest:.2f} s)")
            worst.append(f"{parent}->{child} {seen}")
    if not problems and not worst:
        ages = ", ".join(f"{a}->{b}" for a, b in pairwise(chain))
        return CheckResult(name, True, f"{' -> '.join(chain)} -> "
                                       f"{'/'.join(obs.sensor_frames) or '(no sensors)'} "
                                       f"resolves; {ages} fresh (< "
                                       f"{params.transform_tolerance:.2f} s)")
    shown = problems[:1] + ([f"{len(problems) - 1} more lookup problem(s)"]
                            if len(problems) > 1 else [])
    detail = "; ".join(worst + shown)
    fix = ("restart the node that publishes the stale edge (localization for "
           f"{obs.global_frame}->{obs.odom_frame}, odometry for "
           f"{obs.odom_frame}->{obs.base_frame}) and check its clock and "
           "transform_tolerance")
    return CheckResult(name, False, detail, fix)


def _edge_age(obs: Observations, parent: str, child: str) -> tuple[float, float, float]:
    """``(worst age, when, newest stamp)`` of edge ``parent -> child`` over the span: from
    the observed samples, and at ``now`` from the TF buffer (which also holds samples
    published before observation began)."""
    newest = -math.inf
    if child in obs.tf and obs.tf.parent_of(child) == parent:
        latest = obs.tf.latest_time(child)
        newest = math.inf if latest is None else latest  # static: never stale
    age, at = obs.now - newest, obs.now
    samples = obs.tf_samples.get(f"{parent}->{child}")
    if samples is not None and len(samples):
        span_age, span_at = tf_staleness(samples, obs.start, obs.now)
        newest = max(newest, float(samples[:, 1].max()))
        if span_age > age:
            age, at = span_age, span_at
    return age, at, newest


def lifecycle(obs: Observations, params: HealthParams) -> CheckResult:
    """Every node is ACTIVE."""
    name = "lifecycle"
    if obs.node_states is None:
        return CheckResult(name, True, "not judged: a recording holds no lifecycle states")
    bad = {n: s for n, s in obs.node_states.items() if s != "ACTIVE"}
    if not bad:
        return CheckResult(name, True, f"all {len(obs.node_states)} nodes ACTIVE")
    listed = ", ".join(f"{n} {s}" for n, s in bad.items())
    return CheckResult(name, False, listed,
                       f"activate {', '.join(bad)} (lifecycle configure -> activate; in "
                       "Nav2 the lifecycle_manager's node_names list)")


def controller_active(obs: Observations, params: HealthParams) -> CheckResult:
    """The controller server is ACTIVE (live), or -- from a recording -- commands follow
    the first plan (a plan and no ``/cmd_vel`` after it means no controller ran)."""
    name = "controller_active"
    node = obs.controller_node
    fix = (f"activate {node} (lifecycle activate; check the lifecycle_manager's "
           "node_names and the controller's log for a failed configure)")
    if obs.node_states is not None:
        state = obs.node_states.get(node)
        if state is None:
            return CheckResult(name, False, f"no node named {node}", fix)
        return CheckResult(name, state == "ACTIVE", f"{node} is {state}",
                           "" if state == "ACTIVE" else fix)
    plans = [t for t, _ in obs.plans if any(a <= t <= b for a, b in obs.goal_intervals())]
    if not plans:
        return CheckResult(name, True, "not judged: no plan was published during a goal")
    first = plans[0]
    end = max(b for _, b in obs.goal_intervals())
    times = obs.topic_times.get("/cmd_vel", np.zeros(0))
    after = int(np.count_nonzero((times >= first) & (times <= end)))
    span = end - first
    if span < 1.0 or after >= span:  # a running controller publishes at >= 1 Hz
        return CheckResult(name, True, f"{after} /cmd_vel messages in the {span:.1f} s after "
                                       f"the first plan (t={first:.2f} s)")
    return CheckResult(name, False, f"inferred from the recording: a plan was published at "
                                    f"t={first:.2f} s but only {after} /cmd_vel message(s) "
                                    f"followed in {span:.1f} s", fix)


def plan_frame(obs: Observations, params: HealthParams) -> CheckResult:
    """The plan is expressed in the global costmap's frame."""
    name = "plan_frame"
    if not obs.plans:
        return CheckResult(name, True, "not judged: no plan published yet")
    t, frame = obs.plans[-1]
    if frame == obs.global_frame:
        return CheckResult(name, True, f"/plan in '{frame}' (global costmap frame)")
    return CheckResult(name, False, f"/plan at t={t:.2f} s is in '{frame or '(empty)'}', the "
                                    f"global costmap is in '{obs.global_frame}'",
                       "set the planner's and global costmap's global_frame to the same "
                       "frame (Nav2 global_costmap.global_frame)")


def costmaps_not_lethal(obs: Observations, params: HealthParams) -> list[CheckResult]:
    """Per costmap: not (almost) all lethal, and the robot not standing in lethal cost."""
    out = []
    for cm in obs.costmaps:
        name = f"costmap_not_lethal:{cm.name}"
        pct = 100.0 * cm.blocked_fraction
        under = ("" if cm.robot_cost is None else f"; cost under the robot {cm.robot_cost}")
        detail = f"{pct:.1f}% of {cm.known_cells} known cells lethal/inscribed{under}"
        if cm.known_cells and cm.blocked_fraction >= params.lethal_fraction:
            out.append(CheckResult(name, False, detail,
                                   f"find the {cm.name} layer that marks everything (obstacle "
                                   "layer sources, lethal_cost_threshold, map thresholds) "
                                   "and clear the costmap"))
        elif cm.robot_lethal:
            out.append(CheckResult(name, False, detail + " (footprint in collision)",
                                   "the robot is inside an obstacle in the costmap: clear "
                                   "the costmap around the robot or move it free"))
        else:
            out.append(CheckResult(name, True, detail))
    return out


def localization_covariance(obs: Observations, params: HealthParams) -> CheckResult:
    """The localization estimate's standard deviations stay within bounds."""
    name = "localization_covariance"
    if len(obs.covariance) == 0:
        return CheckResult(name, True, "not judged: no localization estimate published "
                                       "(perfect localization or none)")
    t, sx, sy, syaw = obs.covariance[-1]
    detail = (f"{obs.covariance_topic} at t={t:.2f} s: std x {sx:.3f} m, y {sy:.3f} m, "
              f"yaw {syaw:.3f} rad")
    ok = max(sx, sy) <= params.max_position_std and syaw <= params.max_yaw_std
    return CheckResult(name, ok, detail, "" if ok else
                       "the robot is lost: set an initial pose (/initialpose) or trigger "
                       "global localization, and check the laser and odometry models")


def velocity_limits(obs: Observations, params: HealthParams) -> CheckResult:
    """No velocity limit is zero (live: the controller's parameters; from a recording:
    some command during a planned goal drives forward -- recoveries may back up or spin,
    only the controller drives forward)."""
    name = "velocity_limits"
    if obs.velocity_limits is not None:
        zero = {k: v for k, v in obs.velocity_limits.items() if not v > 0.0}
        if not zero:
            shown = ", ".join(f"{k} {v:g}" for k, v in obs.velocity_limits.items())
            return CheckResult(name, True, shown or "no limits known")
        return CheckResult(name, False, ", ".join(f"{k} = {v:g}" for k, v in zero.items()),
                           "set the maximum velocities in the controller's parameters "
                           "(FollowPath.max_vel_x / max_speed_xy / max_vel_theta) and the "
                           "robot profile above zero")
    intervals = [(a, b) for a, b in obs.goal_intervals()
                 if any(a <= t <= b for t, _ in obs.plans)]
    cmd = obs.cmd[inside(obs.cmd[:, 0], intervals)] if len(obs.cmd) else obs.cmd
    if len(cmd) < 20:
        return CheckResult(name, True, "not judged: fewer than 20 commands during a "
                                       "planned goal")
    fastest = float(cmd[:, 1].max())
    if fastest >= params.min_cmd_linear:
        return CheckResult(name, True, f"commands up to vx {fastest:.2f} m/s over {len(cmd)} "
                                       "commands during planned goals")
    return CheckResult(name, False, f"inferred from the recording: none of {len(cmd)} "
                                    f"commands during a planned goal drove forward (largest "
                                    f"vx {fastest:.2f} m/s)",
                       "check the controller's maximum velocities (max_vel_x, max_speed_xy) "
                       "and speed limits")


def base_consumes_cmd_vel(obs: Observations, params: HealthParams) -> CheckResult:
    """The base executes ``/cmd_vel``: the odometry twist follows non-zero commands."""
    name = "base_consumes_cmd_vel"
    intervals = obs.goal_intervals()
    n, followed = follow_stats(obs.cmd, obs.odom, intervals, min_linear=params.min_cmd_linear,
                               min_angular=params.min_cmd_angular, ratio=params.follow_ratio,
                               lag=params.response_lag)
    subs = ("" if obs.base_subscribers is None
            else f"; /cmd_vel has {obs.base_subscribers} subscriber(s)")
    if n == 0:
        return CheckResult(name, True, f"not judged: no non-zero command during a goal{subs}")
    detail = f"/odom twist followed {followed} of {n} non-zero commands{subs}"
    if followed >= min(params.min_followed, n):
        return CheckResult(name, True, detail)
    return CheckResult(name, False, detail,
                       "make the base (driver or simulator) subscribe to /cmd_vel: check the "
                       "topic name and remappings, the driver's enable/e-stop state and its "
                       "log; if it receives commands but cannot move, see 'progress'")


def progress(obs: Observations, params: HealthParams) -> CheckResult:
    """The robot makes progress while navigating (Nav2 progress checker)."""
    name = "progress"
    radius, allowance = obs.progress_rule or (params.required_movement_radius,
                                              params.movement_time_allowance)
    fix = ("something holds the robot although commands reach the base: look for an "
           "obstacle the sensors cannot see (below the scan plane), wheel slip or a stalled "
           "motor; tune required_movement_radius / movement_time_allowance only if the "
           "robot is legitimately slow")
    aborts = [f for f in obs.follow_path_failures
              if f[1] == int(ControllerErrorCode.FAILED_TO_MAKE_PROGRESS)]
    if aborts:
        t, _, reason = aborts[0]
        return CheckResult(name, False, f"FollowPath aborted at t={t:.2f} s: {reason}", fix)
    trip = progress_trip(obs.odom, obs.goal_intervals(), radius, allowance)
    if trip is not None:
        t, base = trip
        return CheckResult(name, False, f"the robot stayed within {radius:.2f} m of its pose "
                                        f"at t={base:.2f} s until t={t:.2f} s (allowance "
                                        f"{allowance:.1f} s)", fix)
    return CheckResult(name, True, f"no {allowance:.1f} s without {radius:.2f} m of motion "
                                   "during a goal")


def robot_motion(obs: Observations) -> tuple[float, float]:
    """``(largest distance [m] from where a goal began, goal time [s])`` by odometry over
    the goals (net displacement: odometry noise does not add up to motion)."""
    best = 0.0
    for lo, hi in obs.goal_intervals():
        od = obs.odom[(obs.odom[:, 0] >= lo) & (obs.odom[:, 0] <= hi)] if len(obs.odom) else (
            obs.odom)
        if len(od):
            best = max(best, float(np.max(np.hypot(od[:, 1] - od[0, 1], od[:, 2] - od[0, 2]))))
    return best, total_length(obs.goal_intervals())


def all_checks(obs: Observations, params: HealthParams) -> list[CheckResult]:
    """Every health check, in pipeline order (sensors -> TF -> nodes -> maps -> motion)."""
    out = [topic_rate(obs, params, t) for t in ("/scan", "/odom", "/tf")
           if t in obs.expected_rates]
    out.append(map_latched(obs, params))
    out.append(tf_chain(obs, params))
    out.append(lifecycle(obs, params))
    out.append(localization_covariance(obs, params))
    out.append(plan_frame(obs, params))
    out += costmaps_not_lethal(obs, params)
    out.append(cmd_vel_published(obs, params))
    out.append(velocity_limits(obs, params))
    out.append(base_consumes_cmd_vel(obs, params))
    out.append(progress(obs, params))
    return out


def clock_contract(peer: str, health: dict[str, float | int | bool], tolerance: float
                   ) -> CheckResult:
    """The ``clock`` contract of a split stack (issue 21): ``peer`` answers the clock
    exchange, and its clock either agrees with ours within ``tolerance`` or the estimated
    offset is applied to every received stamp (``transport.clock.compensate``).

    ``health``: :meth:`ZenohLink.health` of the peer (``offset_s``, ``round_trip_s``,
    ``exchanges``, ``up``, ``compensated``)."""
    name = f"clock:{peer}"
    if not health.get("exchanges"):
        return CheckResult(name, False, f"no clock exchange with '{peer}' answered",
                           f"start '{peer}' and check transport.listen / transport.connect "
                           f"endpoints and firewalls")
    offset, rtt = float(health["offset_s"]), float(health["round_trip_s"])
    detail = (f"offset of '{peer}' {offset * 1e3:+.1f} ms (round trip {rtt * 1e3:.2f} ms, "
              f"{int(health['exchanges'])} exchanges)")
    if not health.get("up", False):
        return CheckResult(name, False, detail + "; link down now",
                           f"'{peer}' stopped answering: check the link")
    if abs(offset) <= tolerance:
        return CheckResult(name, True, detail)
    if health.get("compensated", False):
        return CheckResult(name, True, detail + "; compensated on receipt")
    return CheckResult(name, False, detail + f" exceeds {tolerance * 1e3:.1f} ms and "
                       f"compensation is off: stamps from '{peer}' are off by "
                       f"{offset:+.3f} s (TF extrapolation errors, dropped data)",
                       "set transport.<name>.clock.compensate: true, or sync the clocks "
                       "(chrony / NTP) on both machines")
