"""Params: unknown keys, wrong types and out-of-range values become one-line ConfigErrors."""

from __future__ import annotations

import pytest
from pydantic import Field

from navstack.core.errors import ConfigError, ConfigErrors
from navstack.core.params import Params


class Limits(Params):
    max_vel_x: float = Field(0.26, gt=0)
    min_vel_x: float = 0.0
    controller_frequency: float = Field(20.0, gt=0, le=1000)


def test_defaults_and_valid_values() -> None:
    p = Limits.from_mapping({"max_vel_x": 0.5, "controller_frequency": 10})
    assert (p.max_vel_x, p.min_vel_x, p.controller_frequency) == (0.5, 0.0, 10.0)
    assert Limits.from_mapping(None) == Limits()
    assert p.updated(min_vel_x=-0.1).min_vel_x == -0.1


def test_unknown_key_with_suggestion() -> None:
    with pytest.raises(ConfigError) as err:
        Limits.from_mapping({"max_vel_xx": 0.5}, file="f.yaml", key_path="controller")
    assert str(err.value) == ("f.yaml: controller.max_vel_xx: unknown key "
                              "(did you mean 'max_vel_x'?)")
    assert err.value.key_path == "controller.max_vel_xx"
    assert err.value.file == "f.yaml"


def test_wrong_type_names_the_key() -> None:
    with pytest.raises(ConfigError) as err:
        Limits.from_mapping({"max_vel_x": "fast"}, file="f.yaml", key_path="controller")
    assert str(err.value) == ("f.yaml: controller.max_vel_x: Input should be a valid number "
                              "(got 'fast')")


def test_out_of_range_names_the_key() -> None:
    with pytest.raises(ConfigError) as err:
        Limits.from_mapping({"max_vel_x": -1.0}, file="f.yaml", key_path="controller")
    assert str(err.value) == ("f.yaml: controller.max_vel_x: Input should be greater than 0 "
                              "(got -1.0)")
    with pytest.raises(ConfigError) as err:
        Limits.from_mapping({"controller_frequency": 5000})
    assert str(err.value) == ("controller_frequency: Input should be less than or equal to 1000 "
                              "(got 5000)")


def test_several_problems_reported_together() -> None:
    with pytest.raises(ConfigErrors) as err:
        Limits.from_mapping({"max_vel_x": 0.0, "foo": 1}, file="f.yaml")
    assert str(err.value).splitlines() == [
        "f.yaml: max_vel_x: Input should be greater than 0 (got 0.0)",
        "f.yaml: foo: unknown key",
    ]
    assert len(err.value.errors) == 2


def test_params_are_frozen() -> None:
    p = Limits()
    with pytest.raises(ValueError, match="frozen"):
        p.max_vel_x = 1.0  # type: ignore[misc]


def test_bool_for_a_float_is_a_type_error() -> None:
    with pytest.raises(ConfigError, match=r"max_vel_x"):
        Limits.from_mapping({"max_vel_x": True})
