"""``navstack bench link``'s figures: the trajectory deviation is a distance between
positions (never time), and the latency bench pairs each command with its own decode."""

from __future__ import annotations

import numpy as np
import pytest

from navstack.benchmarks.link import trajectory_deviation


def test_trajectory_deviation_is_the_symmetric_hausdorff_distance_of_the_paths() -> None:
    a = np.array([[0.0, 0.0], [10.0, 0.0]])
    b = np.array([[0.0, 0.2], [5.0, 0.5], [10.0, 0.2]])
    assert trajectory_deviation(a, b) == pytest.approx(0.5)  # b's corner to a's line
    assert trajectory_deviation(b, a) == pytest.approx(0.5)
    longer = np.array([[0.0, 0.0], [12.0, 0.0]])
    assert trajectory_deviation(a, longer) == pytest.approx(2.0)  # the 2 m a never drove
    # the same path driven later or slower deviates by nothing
    slow = np.column_stack([np.linspace(0.0, 10.0, 301), np.zeros(301)])
    assert trajectory_deviation(a, slow) == pytest.approx(0.0, abs=1e-12)


def test_trajectory_deviation_refuses_time_columns() -> None:
    """A t, x, y array would count a delay in seconds as metres."""
    txy = np.array([[0.0, 0.0, 0.0], [1.0, 10.0, 0.0]])
    with pytest.raises(ValueError, match=r"'a' must be an \(N >= 2, 2\) array of x, y"):
        trajectory_deviation(txy, txy[:, 1:])
    with pytest.raises(ValueError, match="'b' must be"):
        trajectory_deviation(txy[:, 1:], txy[:1, 1:])


@pytest.mark.parametrize("kind", ["udp", "serial"])
def test_link_latency_pairs_each_command_with_its_own_decode(kind: str) -> None:
    """Each latency runs from a command's encode to the vehicle decoding *that* command
    (found by its content), so none is negative -- pairing by count gave -20 ms medians
    once a late decode or a resynchronised frame shifted the count."""
    from navstack.benchmarks.link import measure_link_latency

    lat = measure_link_latency(kind, commands=60, pace=0.0)
    assert 0.0 <= lat["p50_ms"] <= lat["p95_ms"] <= lat["max_ms"]
    assert lat["lost"] < 60
