"""The planners benchmark suite's per-map runner on the bundled arena map."""

from __future__ import annotations

from pathlib import Path

from navstack.benchmarks.planners import run_map, select_peer

DATA = Path(__file__).resolve().parents[1] / "data" / "movingai"


def test_run_map_counts_every_quick_scenario_optimal() -> None:
    name, factory = select_peer()
    assert name in ("pyastar2d", "tcod")
    row, ours, peer = run_map(DATA / "arena.map", True, factory)
    assert row["map"] == "arena" and row["size"] == "49x49"
    assert row["scenarios"] == 8 == len(ours) == len(peer)  # 160 scenarios, every 20th
    assert row["optimal"] == 8 and row["optimal_rate"] == 1.0
    assert row["max_abs_error"] < 1e-4
    assert min(ours) > 0.0 and min(peer) > 0.0
