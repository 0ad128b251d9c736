"""The mars yard course: a georeferenced 100 m yard with rocks, posts from the course YAML
as obstacles, the rover's profile on it, and errors that name the file and key."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from navstack.core.errors import ConfigError
from navstack.sim.course import (
    course_robot,
    course_world,
    ll_to_world,
    load_course,
    world_to_ll,
)
from navstack.sim.worlds import load_world


def test_mars_yard_is_a_100_m_rock_field_with_the_posts_added() -> None:
    course = load_course()
    bare = load_world(course.world)
    world = course_world(course)
    x0, y0, x1, y1 = world.bounds
    assert (x1 - x0, y1 - y0) == pytest.approx((100.0, 100.0))
    for post in course.posts:
        assert bare.is_free(post.x, post.y)  # the posts come from the course, not the world
        assert not world.is_free(post.x, post.y)
        assert world.is_free(post.x + 0.4, post.y)
    gate = {g.name: g for g in course.gates}["gate_a"]
    a, b = (course.post(i) for i in gate.posts)
    assert math.hypot(a.x - b.x, a.y - b.y) == pytest.approx(4.0)
    assert world.is_free((a.x + b.x) / 2, (a.y + b.y) / 2)
    assert world.is_free(world.spawn.x, world.spawn.y)
    occupied = 1.0 - sum(world.is_free(x + 0.5, y + 0.5) for x in range(100)
                         for y in range(100)) / 10_000
    assert 0.01 < occupied < 0.06  # rocks, posts and the boundary


def test_post_legs_are_within_20_m_of_their_post() -> None:
    course = load_course()
    geo = course.georeference
    from navstack.geo.gps_goal import parse_coordinate
    for leg in course.legs:
        if leg.kind != "post":
            continue
        x, y = ll_to_world(geo, parse_coordinate(leg.latitude, kind="latitude"),
                           parse_coordinate(leg.longitude, kind="longitude"))
        post = course.post(leg.post or 0)
        assert math.hypot(post.x - x, post.y - y) <= 20.0


def test_rover_profile_on_the_course() -> None:
    course = load_course()
    rover = course_robot(course)
    s = rover.sensors
    assert s.georeference.world_yaw == 0.35  # map rotated against east-north
    assert (s.gnss.horizontal_noise_std, s.gnss.bias_std, s.gnss.rate_hz) == (2.0, 1.0, 5.0)
    assert (s.imu.rate_hz, s.imu.gyro_noise_std) == (100.0, 0.003)
    assert (rover.kinematics.type, rover.kinematics.max_vel_x) == ("diff_drive", 1.5)
    poly = rover.footprint_model().polygon
    span = poly.max(axis=0) - poly.min(axis=0)
    assert span == pytest.approx([1.2 + 0.1, 0.9 + 0.1])  # body + 0.05 padding a side
    lat, lon = world_to_ll(s.georeference, 30.0, 15.0)
    assert ll_to_world(s.georeference, lat, lon) == pytest.approx((30.0, 15.0), abs=1e-3)


def test_course_errors_name_the_file_and_key(tmp_path: Path) -> None:
    bad = tmp_path / "course.yaml"
    bad.write_text("world: mars_yard\nposts: [{id: 1, x: 5.0, y: 5.0}]\n"
                   "legs: [{name: a, kind: post, post: 7, latitude: 38.4, longitude: -110.8}]\n")
    with pytest.raises(ConfigError, match="post leg 'a' needs post: one of \\[1\\]"):
        load_course(bad)
    bad.write_text("world: mars_yard\nlegs: [{name: a, kind: gnss, latitude: '38,61,0', "
                   "longitude: -110.8}]\n")
    with pytest.raises(ConfigError, match=r"course\.yaml: legs\[0\]\.latitude: '38,61,0' has "
                                          r"minutes or seconds >= 60"):
        load_course(bad)
    bad.write_text("world: mars_yard\ngates: [{name: g, posts: [1, 2]}]\n")
    with pytest.raises(ConfigError, match="gate 'g' names post 1, which is not in posts"):
        load_course(bad)
    bad.write_text("world: mars_yard\nlegz: []\n")
    with pytest.raises(ConfigError, match="legz"):
        load_course(bad)
