"""Secrets for operator interfaces (dashboard token, Telegram bot token) from the
environment or a file -- never from a command-line value, which every user of the machine
can read in ``ps``.

Order: an explicit value given in Python, then the file, then the environment variable.
A file readable by group or others is used but warned about (``chmod 600`` fixes it).
Secret values are never logged or put in error messages.
"""

from __future__ import annotations

import logging
import os
import stat
from pathlib import Path

from navstack.core.errors import NavstackError

__all__ = ["CredentialError", "read_secret"]
_log = logging.getLogger("navstack.credentials")


class CredentialError(NavstackError):
    """A secret could not be read (missing file, empty value); names where it looked."""


def read_secret(what: str, *, value: str | None = None, file: str | Path | None = None,
                env: str | None = None, required: bool = False) -> str | None:
    """The secret ``what`` (e.g. "dashboard token") from ``value``, ``file`` or the
    environment variable ``env``; None when none is given and not ``required``."""
    if value is not None:
        if not value.strip():
            raise CredentialError(f"the {what} is empty")
        return value.strip()
    if file is not None:
        path = Path(file).expanduser()
        try:
            text = path.read_text(encoding="utf-8").strip()
            mode = path.stat().st_mode
        except OSError as exc:
            raise CredentialError(f"cannot read the {what} from {path}: {exc.strerror}; "
                                  f"write it there (one line, chmod 600)") from None
        if not text:
            raise CredentialError(f"{path} is empty; write the {what} in it (one line)")
        if mode & (stat.S_IRWXG | stat.S_IRWXO):
            _log.warning("%s is readable by other users; chmod 600 %s", path, path)
        return text.splitlines()[0].strip()
    if env is not None:
        text = os.environ.get(env, "").strip()
        if text:
            return text
    if required:
        where = " or ".join(x for x in (f"a file (--{what.split()[-1]}-file)" if file is None
                                        else "", f"${env}" if env else "") if x)
        raise CredentialError(f"no {what} given; provide it through {where}")
    return None
