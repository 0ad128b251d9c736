"""``navstack bench link``: the vehicle links' added command latency and the
hardware-in-the-loop demos against their in-process twins.

1. **Link latency** (both links, ``commands`` each): a command is encoded, written on the
   real link (UDP on loopback for the rover's VCU string, a pty for the cart's ``'<fi'``
   packet), read by the simulated vehicle's reader thread and decoded; the wall time
   from "the driver has the twist" to "the vehicle has decoded it" is the added command
   latency.  Commands go out every ``pace`` s (default 2 ms), as a driver's timer would.
   Metrics ``rover_udp_latency_p50_ms`` / ``_p95_ms`` / ``_max_ms`` and
   ``cart_serial_latency_*``; budget p95 <= 5 ms.
2. **HIL demos** (with ``--quick`` only the rover, seed 1): ``navstack demo --robot
   rover --link udp`` and ``--robot golf_cart --link serial`` with seeds 1 and 2
   (:data:`SEEDS`), each also run in process with the same seed; metrics per seed
   (``<robot>_s<seed>_...``) and the worst seed (``<robot>_...``): success,
   collisions, the command latency the demo measured (p95), and the trajectory
   deviation -- the largest distance from a point of either trajectory to the other's
   path (symmetric Hausdorff distance of the x, y positions over 0.1 s samples),
   budget 0.3 m.  Both runs plan deterministically: on simulated time
   the planners count ``max_planning_time`` in expansions, not wall seconds
   (:mod:`navstack.planning.budget`), so only the link can make them differ.
   ``first_goal_deviation_m``: the same over the first leg.  ``sensitivity_1mm_m``: the
   deviation of a third, in-process run whose robot starts 1 mm further forward -- how
   far the route itself carries a difference no link can avoid (a float32, a decimal);
   a deviation at that level is the route's, not the link's.

The wall-clock figures depend on the machine's load; the 1-minute load average is
recorded in the notes.
"""

from __future__ import annotations

import math
import os
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

import numpy as np

from navstack.benchmarks.common import BenchResult
from navstack.core.msgs import Pose2D
from navstack.drivers.errors import MalformedPacket
from navstack.drivers.framing import FixedFramer
from navstack.drivers.golf_cart import (
    CART_COMMAND,
    decode_cart_command,
    encode_cart_command,
    plausible_cart_command,
)
from navstack.drivers.rover_vcu import decode_vcu_command, encode_vcu_command
from navstack.drivers.transport import SerialTransport, Transport, UdpTransport
from navstack.interfaces.demo import run_demo
from navstack.sim.vehicles.far_side import FarSide
from navstack.sim.vehicles.pty import PtyMasterTransport
from navstack.sim.worlds import load_world

LATENCY_BUDGET_MS = 5.0
DEVIATION_BUDGET_M = 0.3


def _percentiles(xs: list[float]) -> dict[str, float]:
    a = np.asarray(xs) * 1e3
    return {"p50_ms": float(np.percentile(a, 50)), "p95_ms": float(np.percentile(a, 95)),
            "max_ms": float(a.max())}


def measure_link_latency(kind: str, commands: int = 2000, pace: float = 0.002
                         ) -> dict[str, float]:
    """Added command latency of one link (module docstring), in ms."""
    tmp = Path(tempfile.mkdtemp(prefix="navstack-bench-link-"))
    decoded: list[tuple[object, float]] = []
    got = threading.Condition()

    def on_command(cmd: object, wall: float) -> None:
        with got:
            decoded.append((cmd, wall))
            got.notify_all()

    far_t: Transport
    if kind == "udp":
        far_t = UdpTransport("vcu", ("127.0.0.1", 0), None)
        far = FarSide("vcu", {"vcu": far_t}, lambda _l, p: decode_vcu_command(p), on_command,
                      ("vcu",))
    else:
        far_t = PtyMasterTransport("steering", tmp / "ttyBENCH",
                                   FixedFramer(CART_COMMAND.size, plausible_cart_command))
        far = FarSide("cart", {"steering": far_t}, lambda _l, p: decode_cart_command(p),
                      on_command, ("steering",))
    far.start()
    driver: Transport
    if kind == "udp":
        assert isinstance(far_t, UdpTransport)
        driver = UdpTransport("vcu", ("127.0.0.1", 0), far_t.local_address)
    else:
        driver = SerialTransport("steering", str(tmp / "ttyBENCH"), 115200)
    driver.open()
    latencies: list[float] = []
    lost = 0
    cursor = 0  # decodes before it belong to earlier commands
    rng = np.random.default_rng(0)
    decode = decode_vcu_command if kind == "udp" else decode_cart_command
    try:
        for _ in range(commands):
            vx, wz = float(rng.uniform(-1, 1)), float(rng.uniform(-0.5, 0.5))
            t0 = time.perf_counter()
            packet = encode_vcu_command(vx, wz) if kind == "udp" else \
                encode_cart_command(vx, 0.3 * wz)
            if not driver.write(packet):
                lost += 1
                continue
            # the decode of *this* packet, found by its content: a late decode of an
            # earlier command, or bytes the framer resynchronised on, are not it
            expected = decode(packet)
            start = cursor

            def arrived(expected: object = expected, start: int = start) -> bool:
                return any(c == expected for c, _ in decoded[start:])

            with got:
                if not got.wait_for(arrived, timeout=0.5):
                    lost += 1
                    cursor = len(decoded)
                    continue
                k = next(i for i in range(start, len(decoded)) if decoded[i][0] == expected)
                latencies.append(decoded[k][1] - t0)
                cursor = k + 1
            time.sleep(pace)
    except MalformedPacket:
        lost += 1
    finally:
        driver.close()
        far.kill()
        for f in tmp.iterdir():
            f.unlink()
        tmp.rmdir()
    if not latencies:
        raise RuntimeError(f"bench link ({kind}): none of {commands} commands reached the "
                           f"vehicle; driver link: {driver.stats}; vehicle link: "
                           f"{far_t.stats}")
    return {**_percentiles(latencies), "lost": float(lost)}


def trajectory_deviation(a: np.ndarray, b: np.ndarray) -> float:
    """Symmetric Hausdorff distance [m] between two (N, 2) sampled trajectories, each
    point measured to the other's polyline.  Positions only: a ``t, x, y`` array would
    count a delay in seconds as metres (the cause of the rover's unexplained 0.3-0.6 m
    before), so anything but two columns is refused."""
    for name, arr in (("a", a), ("b", b)):
        if arr.ndim != 2 or arr.shape[1] != 2 or len(arr) < 2:
            raise ValueError(f"trajectory_deviation: '{name}' must be an (N >= 2, 2) array "
                             f"of x, y positions, got shape {arr.shape}")
    def to_path(points: np.ndarray, path: np.ndarray) -> float:
        p0, d = path[:-1], np.diff(path, axis=0)
        length2 = np.maximum((d ** 2).sum(1), 1e-12)
        worst = 0.0
        for chunk in np.array_split(points, max(1, len(points) // 256)):
            t = np.clip(((chunk[:, None, :] - p0[None]) * d[None]).sum(2) / length2, 0.0, 1.0)
            proj = p0[None] + t[..., None] * d[None]
            worst = max(worst, float(np.sqrt(((proj - chunk[:, None, :]) ** 2).sum(2))
                                     .min(1).max()))
        return worst
    return max(to_path(a, b), to_path(b, a))


SENSITIVITY_OFFSET_M = 0.001
"""How far the sensitivity run's spawn moves the robot forward [m]."""


def compare_demo(robot: str, link: str, out: Path, seed: int = 1,
                 sensitivity: bool = True) -> dict[str, Any]:
    """The demo in process and through ``link``; success, collisions, deviation, latency.

    ``sensitivity``: also run in process with the robot spawned 1 mm forward, and report
    that run's deviation from the reference -- the route's own sensitivity, the floor
    under any comparison that is not bit-exact (docs/drivers.md)."""
    t0 = time.perf_counter()
    ref = run_demo(out / f"{robot}-inproc", seed, robot=robot, show_progress=False)
    t1 = time.perf_counter()
    hil = run_demo(out / f"{robot}-{link}", seed, robot=robot, show_progress=False,
                   link=link)  # type: ignore[arg-type]
    t2 = time.perf_counter()
    a = _trajectory(out / f"{robot}-inproc")
    b = _trajectory(out / f"{robot}-{link}")
    lat = hil["link"]["command_latency"]
    case: dict[str, Any] = {
        "robot": robot, "link": link, "inproc_success": ref["success"],
        "hil_success": hil["success"], "hil_collisions": hil["collisions"],
        "inproc_collisions": ref["collisions"],
        "deviation_m": round(trajectory_deviation(a[:, 1:3], b[:, 1:3]), 4),
        "first_goal_deviation_m": round(_first_goal_deviation(a, b, ref), 4),
        "hil_latency_p50_ms": lat["p50_ms"], "hil_latency_p95_ms": lat["p95_ms"],
        "hil_latency_max_ms": lat["max_ms"], "commands": hil["link"]["commands_sent"],
        "sync_timeouts": hil["link"]["sync_timeouts"],
        "sim_time_s": hil["sim_time_s"], "inproc_wall_s": round(t1 - t0, 1),
        "hil_wall_s": round(t2 - t1, 1)}
    if sensitivity:
        spawn = load_world(ref["world"]).spawn
        moved = Pose2D(spawn.x + SENSITIVITY_OFFSET_M * math.cos(spawn.theta),
                       spawn.y + SENSITIVITY_OFFSET_M * math.sin(spawn.theta), spawn.theta)
        run_demo(out / f"{robot}-moved", seed, robot=robot, show_progress=False, spawn=moved)
        c = _trajectory(out / f"{robot}-moved")
        case["sensitivity_1mm_m"] = round(trajectory_deviation(a[:, 1:3], c[:, 1:3]), 4)
        case["sensitivity_1mm_first_goal_m"] = round(_first_goal_deviation(a, c, ref), 4)
    return case


def _trajectory(out: Path) -> np.ndarray:
    """``(N, 3)``: t, x, y of a demo's true trajectory."""
    return np.loadtxt(out / "trajectory.csv", delimiter=",", skiprows=1)[:, :3]


def _first_goal_deviation(a: np.ndarray, b: np.ndarray, ref: dict[str, Any]) -> float:
    """Deviation over the first leg: up to the reference's first goal time, and ``b``
    up to the point nearest the reference's end of that leg."""
    t_end = ref["goals"][0]["time_s"]
    leg_a = a[a[:, 0] <= t_end + 1e-9, 1:3]
    end = leg_a[-1]
    k = int(np.argmin(np.hypot(b[:, 1] - end[0], b[:, 2] - end[1])))
    return trajectory_deviation(leg_a, b[:k + 1, 1:3])


SEEDS = (1, 2)
"""Seeds of the HIL comparisons (the route's sensitivity is measured on the first)."""


def run(quick: bool, data_dir: Path, commands: int = 2000) -> BenchResult:
    result = BenchResult("link", show_cases=True)
    loads = [os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")]
    for kind, name in (("udp", "rover_udp"), ("serial", "cart_serial")):
        lat = measure_link_latency(kind, 500 if quick else commands)
        for key in ("p50_ms", "p95_ms", "max_ms"):
            result.metrics[f"{name}_latency_{key}"] = round(lat[key], 4)
        result.metrics[f"{name}_lost"] = lat["lost"]
    robots = [("rover", "udp")] + ([] if quick else [("golf_cart", "serial")])
    seeds = SEEDS[:1] if quick else SEEDS
    with tempfile.TemporaryDirectory(prefix="navstack-bench-hil-") as tmp:
        for robot, link in robots:
            worst: dict[str, float] = {}
            for seed in seeds:
                case = compare_demo(robot, link, Path(tmp) / f"seed{seed}", seed=seed,
                                    sensitivity=seed == seeds[0])
                case["seed"] = seed
                case["load_1min"] = round(os.getloadavg()[0], 1) \
                    if hasattr(os, "getloadavg") else float("nan")
                loads.append(case["load_1min"])
                result.cases.append(case)
                for key in ("hil_collisions", "deviation_m", "first_goal_deviation_m",
                            "sensitivity_1mm_m", "hil_latency_p95_ms"):
                    if key in case:
                        result.metrics[f"{robot}_s{seed}_{key}"] = float(case[key])
                        worst[key] = max(worst.get(key, -math.inf), float(case[key]))
                result.metrics[f"{robot}_s{seed}_hil_success"] = float(case["hil_success"])
            for key, value in worst.items():  # the worst seed against the budgets
                result.metrics[f"{robot}_{key}"] = value
    result.notes.append(f"budgets: latency p95 <= {LATENCY_BUDGET_MS} ms, trajectory "
                        f"deviation <= {DEVIATION_BUDGET_M} m (worst of seeds "
                        f"{', '.join(map(str, seeds))}); 1-minute load average "
                        f"{np.median(loads):.1f} (median; {min(loads):.1f}-{max(loads):.1f}) "
                        f"on {os.cpu_count()} CPUs")
    return result
