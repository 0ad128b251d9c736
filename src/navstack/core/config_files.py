"""YAML parameter files: reading them and Nav2's ``ros__parameters`` layout.

Pure file reading shared by every layer (algorithm parameter models load their own files,
e.g. robot_localization's EKF): every problem is a :class:`~navstack.core.errors.ConfigError`
whose one-line text names the file and the key path -- never a traceback.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import yaml

from navstack.core.errors import ConfigError, did_you_mean

ROS_PARAMETERS = "ros__parameters"


def load_yaml(path: str | Path) -> dict[str, Any]:
    """Read a YAML mapping; missing files, syntax errors and non-mappings are ConfigErrors."""
    p = Path(path)
    if not p.is_file():
        raise ConfigError("file not found", file=str(p),
                          suggestion="check the path" if not p.exists() else "it is a directory")
    try:
        data = yaml.safe_load(p.read_text())
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark
        where = f"line {mark.line + 1}, column {mark.column + 1}: " if mark else ""
        raise ConfigError(f"invalid YAML: {where}{exc.problem}", file=str(p)) from None
    except (yaml.YAMLError, UnicodeDecodeError) as exc:
        raise ConfigError(f"invalid YAML: {exc}", file=str(p)) from None
    if data is None:
        return {}
    if not isinstance(data, dict):
        raise ConfigError(f"top level must be a mapping of keys, got {type(data).__name__}",
                          file=str(p))
    return data


def ros_parameters(data: Mapping[str, Any], server: str, *, file: str = "",
                   required: bool = False) -> dict[str, Any]:
    """Parameters of one Nav2 server from a parameter file's data.

    Accepts ``server: {ros__parameters: {...}}``, the nested costmap form
    ``global_costmap: {global_costmap: {ros__parameters: {...}}}``, and merges the wildcard
    ``/**: {ros__parameters: {...}}`` underneath the server's own values.
    """
    merged: dict[str, Any] = {}
    wildcard = data.get("/**")
    if isinstance(wildcard, Mapping) and isinstance(wildcard.get(ROS_PARAMETERS), Mapping):
        merged.update(wildcard[ROS_PARAMETERS])
    node = data.get(server)
    if node is None:
        if required:
            raise ConfigError(f"no parameters for '{server}'", file=file, key_path=server,
                              suggestion=did_you_mean(server, data).strip(" ()")
                              or f"add '{server}: {ROS_PARAMETERS}: ...'")
        return merged
    if not isinstance(node, Mapping):
        raise ConfigError("must be a mapping", file=file, key_path=server)
    if ROS_PARAMETERS not in node and isinstance(node.get(server), Mapping):
        node = node[server]  # nested costmap layout
        server = f"{server}.{server}"
    params = node.get(ROS_PARAMETERS)
    if params is None:
        unknown = [k for k in node if k != ROS_PARAMETERS]
        hint = did_you_mean(unknown[0], [ROS_PARAMETERS]).strip(" ()") if unknown else ""
        raise ConfigError(f"missing '{ROS_PARAMETERS}'", file=file, key_path=server,
                          suggestion=hint or f"nest the values under '{ROS_PARAMETERS}:'")
    if not isinstance(params, Mapping):
        raise ConfigError("must be a mapping", file=file, key_path=f"{server}.{ROS_PARAMETERS}")
    merged.update(params)
    return merged
