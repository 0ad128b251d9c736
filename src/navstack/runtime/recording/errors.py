"""Typed errors of recording, replay and bag import.

Each error is one line that names the bag (and the topic or message type when one is
involved) and says what to do, so the CLI can print it as ``error: ...`` unchanged.
They subclass :class:`~navstack.core.errors.NavstackError` (``BagError``) and, where a
standard exception fits, ``FileNotFoundError`` / ``FileExistsError`` / ``ValueError`` too.
"""

from __future__ import annotations

from navstack.core.errors import NavstackError


class BagError(NavstackError):
    """Base of every recording / replay / import error."""


class BagNotFoundError(BagError, FileNotFoundError):
    """The bag path does not exist."""

    def __init__(self, path: str) -> None:
        super().__init__(f"{path}: no such bag (give a rosbag2 folder with metadata.yaml, "
                         f"an .mcap or .db3 file, or a ROS 1 .bag file)")

    def __str__(self) -> str:
        return str(self.args[0])


class BagFormatError(BagError, ValueError):
    """The path exists but is not a bag rosbags can open (or the bag is damaged)."""


class BagExistsError(BagError, FileExistsError):
    """The output bag folder already exists (replacing is off, or it is not a bag)."""

    def __init__(self, path: str, is_bag: bool = False) -> None:
        if is_bag:
            text = (f"{path}: a bag already exists there; remove it, choose another output "
                    f"path or allow replacing it (--force)")
        else:
            text = (f"{path}: output folder exists and is not a bag navstack wrote; remove it "
                    f"or choose another output path")
        super().__init__(text)

    def __str__(self) -> str:
        return str(self.args[0])


class UnsupportedTypeError(BagError, ValueError):
    """A topic carries a message type that has no navstack <-> ROS 2 conversion."""
