"""Lifecycle transitions, timers gated by state, and actions goal/feedback/result/cancel."""

import pytest

from navstack.core.errors import BusError, LifecycleError
from navstack.core.msgs import Float64
from navstack.runtime.actions import ActionClient, ActionServer, GoalHandle, GoalStatus
from navstack.runtime.node import LifecycleState, Node, Runtime


class Counter(Node):
    def __init__(self, rt: Runtime) -> None:
        super().__init__("counter", rt)
        self.ticks = 0
        self.heard: list[float] = []

    def on_configure(self) -> None:
        self.create_timer(0.1, self._tick)
        self.create_subscription("/in", Float64, lambda m: self.heard.append(m.data))

    def _tick(self) -> None:
        self.ticks += 1


def test_lifecycle_gates_timers_and_subscriptions() -> None:
    rt = Runtime()
    node = Counter(rt)
    pub = rt.bus.publisher("/in", Float64)
    node.configure()
    pub.publish(Float64(1.0))
    rt.scheduler.run_until(1.0)
    assert node.state is LifecycleState.INACTIVE
    assert node.ticks == 0 and node.heard == [] and node.dropped_inactive == 1
    node.activate()
    pub.publish(Float64(2.0))
    rt.scheduler.run_until(2.0)
    assert node.ticks == 10 and node.heard == [2.0]
    node.deactivate()
    rt.scheduler.run_until(3.0)
    assert node.ticks == 10
    with pytest.raises(LifecycleError, match="node 'counter': cannot activate from UNCONFIGURED"):
        node.cleanup()
        node.activate()
    node.shutdown()
    assert node.state is LifecycleState.FINALIZED


def test_duplicate_node_name_refused() -> None:
    rt = Runtime()
    Counter(rt)
    with pytest.raises(LifecycleError, match="a node named 'counter' already exists"):
        Counter(rt)


def test_action_goal_feedback_result_and_cancel() -> None:
    rt = Runtime()
    sched = rt.scheduler
    active: list[GoalHandle[int]] = []

    def on_goal(h: GoalHandle[int]) -> bool | str:
        if h.goal < 0:
            return "goal must be non-negative"
        h.execute()
        active.append(h)
        return True

    def on_cancel(h: GoalHandle[int]) -> None:
        h.canceled(result=h.feedback)

    ActionServer(rt.bus, "/count", on_goal, on_cancel)

    def step() -> None:
        for h in list(active):
            if h.done:
                active.remove(h)
                continue
            n = (h.feedback or 0) + 1
            h.publish_feedback(n)
            if n >= h.goal:
                h.succeed(n)

    sched.create_timer(0.1, step)
    client: ActionClient[int] = ActionClient(rt.bus, "/count")
    feedback: list[int] = []
    h = client.send_goal(3, feedback_cb=feedback.append)
    sched.run_until(1.0)
    assert h.status is GoalStatus.SUCCEEDED and h.result is not None and h.result.result == 3
    assert feedback == [1, 2, 3]

    h2 = client.send_goal(100)
    sched.run_until(1.25)
    h2.cancel()
    assert h2.status is GoalStatus.CANCELED and h2.result is not None
    assert h2.result.result == 2

    h3 = client.send_goal(-1)
    assert h3.status is GoalStatus.REJECTED and h3.result is not None
    assert h3.result.error_msg == "goal must be non-negative"
    with pytest.raises(BusError, match="a failed goal needs a reason"):
        GoalHandle("/x", 1, 0).fail(1, "")


def test_same_seed_same_run() -> None:
    import numpy as np

    def run(seed: int) -> list[float]:
        rt = Runtime()
        rng = np.random.default_rng(seed)
        out: list[float] = []
        pub = rt.bus.publisher("/noise", Float64)
        rt.scheduler.create_timer(0.01, lambda: pub.publish(Float64(float(rng.normal()))))
        rt.bus.subscribe("/noise", Float64, lambda m: out.append(m.data + rt.now))
        rt.scheduler.run_until(2.0)
        return out

    assert run(7) == run(7)
    assert run(7) != run(8)


def test_bad_transform_is_counted_and_the_rest_still_land() -> None:
    from navstack.core.msgs import Header, TFMessage, Transform, TransformStamped, Vector3
    from navstack.core.msgs.geometry_msgs import Quaternion

    rt = Runtime()
    good = TransformStamped(Header(1.0, "odom"), "base_link", Transform(Vector3(1.0, 0, 0)))
    bad = TransformStamped(Header(1.0, "map"), "odom",
                           Transform(Vector3(float("nan"), 0, 0), Quaternion()))
    rt.bus.publisher("/tf", TFMessage).publish(TFMessage((bad, good)))
    rt.scheduler.run_until(1.0)
    assert rt.tf_rejections == 1 and "odom" in rt.last_tf_rejection
    assert rt.tf.lookup_pose2d("odom", "base_link").x == 1.0
