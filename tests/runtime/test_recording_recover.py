"""A recording cut off mid-write (killed, disk full): the reader names the problem and the
fix, and ``recover_mcap`` / ``navstack bag recover`` keep every complete message."""

from __future__ import annotations

from pathlib import Path

import pytest
from typer.testing import CliRunner

from navstack.app import app
from navstack.core.msgs import Header, LaserScan, Odometry
from navstack.runtime.recording import BagFormatError, BagReader, BagWriter
from navstack.runtime.recording.recover import recover_mcap

N = 3000  # > 1 MiB of scans: the bag has several chunks


def _bag(path: Path) -> Path:
    w = BagWriter(path)
    for k in range(N):
        t = 0.01 * k
        w.write("/odom", Odometry(Header(t, "odom"), "base_link"), t)
        if k % 10 == 0:
            w.write("/scan", LaserScan(Header(t, "laser"), -3.1, 3.1, 0.01, 0.0, 0.1, 0.1, 30.0,
                                       tuple(float(i % 7) for i in range(620))), t)
    w.close()
    return path


def _log_times(path: Path, topic: str) -> list[float]:
    with BagReader(path) as bag:
        return [m.log_time for m in bag.messages([topic])]


@pytest.fixture(scope="module")
def original(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return _bag(tmp_path_factory.mktemp("rec") / "bag")


def _cut(original: Path, folder: Path, fraction: float) -> Path:
    cut = folder / "cut"
    cut.mkdir()
    data = next(original.glob("*.mcap")).read_bytes()
    (cut / "cut.mcap").write_bytes(data[: int(len(data) * fraction)])
    return cut


@pytest.mark.parametrize("fraction", [0.3, 0.75])
def test_truncated_bag_is_named_and_its_prefix_recovered(original: Path, tmp_path: Path,
                                                         fraction: float) -> None:
    cut = _cut(original, tmp_path, fraction)
    with pytest.raises(BagFormatError) as info:
        BagReader(cut).open()
    assert str(info.value) == (
        f"{cut}: the MCAP file cut.mcap is truncated (no summary and footer: the recording "
        f"was cut off, e.g. killed or out of disk); recover its readable messages with "
        f"`navstack bag recover {cut} --out FIXED`")
    rep = recover_mcap(cut, tmp_path / "fixed")
    assert not rep.complete and "cut off" in rep.stopped
    odom = _log_times(tmp_path / "fixed", "/odom")
    scans = _log_times(tmp_path / "fixed", "/scan")
    # what was recovered is exactly the start of the recording, nothing invented
    assert odom == _log_times(original, "/odom")[: len(odom)]
    assert scans == _log_times(original, "/scan")[: len(scans)]
    assert rep.counts == {"/odom": len(odom), "/scan": len(scans)}
    assert 0.5 * fraction * N < len(odom) < N and scans


def test_recovering_a_complete_bag_keeps_everything(original: Path, tmp_path: Path) -> None:
    rep = recover_mcap(original, tmp_path / "copy")
    assert rep.complete and rep.stopped == ""
    assert rep.counts == {"/odom": N, "/scan": N // 10}
    with BagReader(tmp_path / "copy") as bag:
        assert {k: (v.ros_type, v.count) for k, v in bag.topics().items()} == {
            "/odom": ("nav_msgs/msg/Odometry", N), "/scan": ("sensor_msgs/msg/LaserScan", N // 10)}


def test_bag_recover_command(original: Path, tmp_path: Path) -> None:
    cut = _cut(original, tmp_path, 0.5)
    runner = CliRunner()
    res = runner.invoke(app, ["bag", "recover", str(cut), "--out", str(tmp_path / "fixed")])
    assert res.exit_code == 0, res.output
    assert res.stdout.startswith("recovered ") and "cut off" in res.stdout
    assert runner.invoke(app, ["bag", "info", str(tmp_path / "fixed")]).exit_code == 0
    res = runner.invoke(app, ["bag", "recover", str(cut), "--out", str(tmp_path / "fixed")])
    assert res.exit_code == 2 and "--force" in res.output
    res = runner.invoke(app, ["bag", "recover", str(cut), "--out", str(tmp_path / "fixed"),
                              "--force"])
    assert res.exit_code == 0, res.output
