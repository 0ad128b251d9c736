"""The predefined ArUco dictionaries of OpenCV, by name.

Shared by the simulator (which draws markers) and ``perception.aruco`` (which detects
them), so both accept the same names and refuse unknown ones the same way.  The names
are OpenCV's constants (``cv2.aruco.DICT_4X4_50`` ... ``DICT_ARUCO_ORIGINAL``, the
AprilTag families); OpenCV is imported only when a dictionary object is asked for.
"""

from __future__ import annotations

from typing import Any

from navstack.core.errors import ConfigError, did_you_mean

DICTIONARY_NAMES: tuple[str, ...] = (
    "DICT_4X4_50", "DICT_4X4_100", "DICT_4X4_250", "DICT_4X4_1000",
    "DICT_5X5_50", "DICT_5X5_100", "DICT_5X5_250", "DICT_5X5_1000",
    "DICT_6X6_50", "DICT_6X6_100", "DICT_6X6_250", "DICT_6X6_1000",
    "DICT_7X7_50", "DICT_7X7_100", "DICT_7X7_250", "DICT_7X7_1000",
    "DICT_ARUCO_ORIGINAL", "DICT_ARUCO_MIP_36h12",
    "DICT_APRILTAG_16h5", "DICT_APRILTAG_25h9", "DICT_APRILTAG_36h10",
    "DICT_APRILTAG_36h11",
)
"""Every predefined dictionary name OpenCV's ``getPredefinedDictionary`` accepts."""


def check_dictionary_name(name: str, key_path: str = "dictionary", file: str = "") -> str:
    """``name`` normalised (a missing ``DICT_`` prefix and lower case are accepted), or a
    :class:`ConfigError` naming the key and the closest known dictionary."""
    text = str(name).strip()
    candidate = text if text.upper().startswith("DICT_") else f"DICT_{text}"
    by_upper = {n.upper(): n for n in DICTIONARY_NAMES}
    found = by_upper.get(candidate.upper())
    if found is None:
        hint = did_you_mean(candidate.upper(), by_upper).strip(" ()")
        raise ConfigError(f"unknown ArUco dictionary '{name}'", file=file, key_path=key_path,
                          suggestion=hint or f"use one of {', '.join(DICTIONARY_NAMES)}")
    return found


def marker_count(name: str) -> int:
    """How many ids the dictionary holds (ids run 0 .. count-1)."""
    return int(get_dictionary(name).bytesList.shape[0])


def get_dictionary(name: str) -> Any:
    """The OpenCV ``cv2.aruco.Dictionary`` named ``name`` (see :data:`DICTIONARY_NAMES`)."""
    import cv2

    return cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, check_dictionary_name(name)))


def check_marker_id(name: str, marker_id: int, key_path: str = "id", file: str = "") -> int:
    """``marker_id`` if the dictionary has it, else a :class:`ConfigError`."""
    count = marker_count(name)
    if not 0 <= int(marker_id) < count:
        raise ConfigError(f"marker id {marker_id} is not in {check_dictionary_name(name)} "
                          f"(ids 0..{count - 1})", file=file, key_path=key_path)
    return int(marker_id)


__all__ = ["DICTIONARY_NAMES", "check_dictionary_name", "check_marker_id",
           "get_dictionary", "marker_count"]
