"""Config loading: YAML errors, Nav2 layout, stack files — every error names the key."""

from pathlib import Path

import pytest

from navstack.core.errors import ConfigError
from navstack.runtime.config import load_stack, load_yaml, ros_parameters


def write(tmp_path: Path, text: str, name: str = "stack.yaml") -> Path:
    p = tmp_path / name
    p.write_text(text)
    return p


def test_missing_file(tmp_path: Path) -> None:
    with pytest.raises(ConfigError) as e:
        load_yaml(tmp_path / "nope.yaml")
    assert str(e.value) == f"{tmp_path / 'nope.yaml'}: file not found (check the path)"


def test_yaml_syntax_error_has_line(tmp_path: Path) -> None:
    p = write(tmp_path, "a: 1\nb: [1, 2\n")
    with pytest.raises(ConfigError, match=r"stack.yaml: invalid YAML: line 3, column 1"):
        load_yaml(p)


def test_top_level_must_be_mapping(tmp_path: Path) -> None:
    p = write(tmp_path, "- 1\n- 2\n")
    with pytest.raises(ConfigError, match="top level must be a mapping of keys, got list"):
        load_yaml(p)


def test_unknown_key_did_you_mean(tmp_path: Path) -> None:
    p = write(tmp_path, "world:\n  nmae: office\n")
    with pytest.raises(ConfigError) as e:
        load_stack(p)
    assert str(e.value) == f"{p}: world.nmae: unknown key (did you mean 'name'?)"


def test_wrong_type_names_key(tmp_path: Path) -> None:
    p = write(tmp_path, "sim:\n  duration: soon\n")
    with pytest.raises(ConfigError) as e:
        load_stack(p)
    assert str(e.value).startswith(f"{p}: sim.duration: Input should be a valid number")
    assert "'soon'" in str(e.value)


def test_out_of_range_names_key(tmp_path: Path) -> None:
    p = write(tmp_path, "sim:\n  duration: -5\n")
    with pytest.raises(ConfigError) as e:
        load_stack(p)
    assert str(e.value) == f"{p}: sim.duration: Input should be greater than 0 (got -5)"


def test_several_errors_reported_together(tmp_path: Path) -> None:
    p = write(tmp_path, "seed: x\nsim:\n  rate: 0\n")
    with pytest.raises(ConfigError) as e:
        load_stack(p)
    lines = str(e.value).splitlines()
    assert len(lines) == 2
    assert lines[0].startswith(f"{p}: seed: ") and lines[1].startswith(f"{p}: sim.rate: ")


def test_nav2_layout_is_read_as_is(tmp_path: Path) -> None:
    nav2 = write(tmp_path, """
/**:
  ros__parameters:
    use_sim_time: true
controller_server:
  ros__parameters:
    controller_frequency: 20.0
    FollowPath:
      plugin: "dwb_core::DWBLocalPlanner"
      max_vel_x: 0.26
global_costmap:
  global_costmap:
    ros__parameters:
      resolution: 0.05
""", "nav2_params.yaml")
    data = load_yaml(nav2)
    ctrl = ros_parameters(data, "controller_server", file=str(nav2))
    assert ctrl["controller_frequency"] == 20.0
    assert ctrl["FollowPath"]["plugin"] == "dwb_core::DWBLocalPlanner"
    assert ctrl["use_sim_time"] is True
    assert ros_parameters(data, "global_costmap")["resolution"] == 0.05
    stack = write(tmp_path, "navigation: nav2_params.yaml\n")
    cfg = load_stack(stack)
    ctrl_params = cfg.navigation_params()["controller_server"]["ros__parameters"]
    assert ctrl_params["controller_frequency"] == 20.0


def test_nav2_layout_errors(tmp_path: Path) -> None:
    data = {"controller_server": {"ros_parameters": {"a": 1}}}
    with pytest.raises(ConfigError) as e:
        ros_parameters(data, "controller_server", file="nav2.yaml")
    assert str(e.value) == ("nav2.yaml: controller_server: missing 'ros__parameters' "
                            "(did you mean 'ros__parameters'?)")
    with pytest.raises(ConfigError) as e:
        ros_parameters({"controler_server": {}}, "controller_server", file="nav2.yaml",
                       required=True)
    assert str(e.value) == ("nav2.yaml: controller_server: no parameters for 'controller_server' "
                            "(did you mean 'controler_server'?)")


def test_plugin_section_must_be_a_mapping() -> None:
    from navstack.navigation.plugins import plugin_section

    with pytest.raises(ConfigError) as e:
        plugin_section({"FollowPath": "dwb"}, "FollowPath", "dwb_core::DWBLocalPlanner",
                       file="nav2.yaml", key_path="controller_server")
    assert str(e.value) == "nav2.yaml: controller_server.FollowPath: must be a mapping, got str"
