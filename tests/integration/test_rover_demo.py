"""Acceptance 5 of issue 20: ``navstack demo --robot rover`` -- one GNSS, one gate and one
post leg of the mars yard course, run by the rover's behaviour tree -- succeeds through
the UDP VCU link (commands out as VCU strings, odometry and GNSS back as VCU packets) with
no collision."""

from __future__ import annotations

from pathlib import Path

from navstack.interfaces.rover import run_rover_demo


def test_rover_demo_through_the_udp_vcu_link(tmp_path: Path) -> None:
    report = run_rover_demo(tmp_path, seed=1, link="udp", show_progress=False)
    legs = report["legs"]
    assert [leg["kind"] for leg in legs] == ["gnss", "gate", "post"]
    assert report["success"], legs
    assert report["collisions"] == 0
    gate, post = legs[1], legs[2]
    assert gate["crossings"] and gate["crossings"][-1]["heading_off_normal_deg"] <= 45.0
    assert post["true_post_m"]["2"] <= 2.0
    link = report["link"]
    assert link["kind"] == "udp" and link["link_losses"] == 0
    assert link["commands_sent"] > 1000 and link["links"]["vcu"]["malformed"] == 0
    assert (tmp_path / "report.md").read_text().startswith("# navstack rover demo -- SUCCESS")
