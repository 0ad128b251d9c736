"""Joy -> Twist with teleop_twist_joy's semantics (pure; ``teleop_twist_joy`` parameters).

Axes are scaled by ``scale_linear`` / ``scale_angular`` while ``enable_button`` is held,
by the ``*_turbo`` scales while ``enable_turbo_button`` is held (turbo wins), and with
``require_enable_button: false`` whenever no turbo is pressed.  When the enable button is
released one zero Twist is sent, then nothing (``sent_disable_msg``), so the robot stops
and other twist_mux inputs take over after the joystick's timeout.
"""

from __future__ import annotations

from pydantic import Field

from navstack.core.msgs import Joy, Twist2D
from navstack.core.params import Params

__all__ = ["TeleopJoy", "TeleopJoyParams"]


class TeleopJoyParams(Params):
    """teleop_twist_joy parameters (names and defaults); axis maps are ``{x, y, yaw}``."""

    enable_button: int = Field(0, ge=0)
    enable_turbo_button: int = Field(-1, ge=-1)
    require_enable_button: bool = True
    axis_linear: dict[str, int] = Field(default_factory=lambda: {"x": 1})
    scale_linear: dict[str, float] = Field(default_factory=lambda: {"x": 0.5})
    scale_linear_turbo: dict[str, float] = Field(default_factory=lambda: {"x": 1.0})
    axis_angular: dict[str, int] = Field(default_factory=lambda: {"yaw": 0})
    scale_angular: dict[str, float] = Field(default_factory=lambda: {"yaw": 0.5})
    scale_angular_turbo: dict[str, float] = Field(default_factory=lambda: {"yaw": 1.0})


def _button(joy: Joy, i: int) -> bool:
    return 0 <= i < len(joy.buttons) and joy.buttons[i] != 0


def _axis(joy: Joy, axes: dict[str, int], scales: dict[str, float], key: str) -> float:
    i = axes.get(key, -1)
    if i < 0 or i >= len(joy.axes):
        return 0.0
    return float(joy.axes[i]) * scales.get(key, 0.0)


class TeleopJoy:
    """``joy(msg)`` -> the Twist to publish, or ``None`` (publish nothing)."""

    def __init__(self, params: TeleopJoyParams | None = None) -> None:
        self.params = params or TeleopJoyParams()
        self.sent_disable_msg = False

    def joy(self, msg: Joy) -> Twist2D | None:
        p = self.params
        if p.enable_turbo_button >= 0 and _button(msg, p.enable_turbo_button):
            lin, ang = p.scale_linear_turbo, p.scale_angular_turbo
        elif not p.require_enable_button or _button(msg, p.enable_button):
            lin, ang = p.scale_linear, p.scale_angular
        else:
            if self.sent_disable_msg:
                return None
            self.sent_disable_msg = True
            return Twist2D()
        self.sent_disable_msg = False
        return Twist2D(_axis(msg, p.axis_linear, lin, "x"), _axis(msg, p.axis_linear, lin, "y"),
                       _axis(msg, p.axis_angular, ang, "yaw"))
