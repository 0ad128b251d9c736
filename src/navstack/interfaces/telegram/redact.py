"""Keep a secret out of every log record while it is in use.

The Bot API puts the bot token in every URL (``/bot<token>/getUpdates``): httpx logs each
request URL at INFO, and python-telegram-bot's ``InvalidToken`` message quotes the token.
:class:`TokenRedactor` is a ``logging.Filter`` installed on the loggers of
python-telegram-bot, httpx, httpcore and navstack (each existing logger of those
families: a filter on a parent logger does not see its children's records); it rewrites
the message, its arguments and any formatted traceback of each record, replacing the
token by ``<token>``.
"""

from __future__ import annotations

import logging

__all__ = ["TokenRedactor"]

FAMILIES = ("telegram", "httpx", "httpcore", "navstack", "asyncio")
MASK = "<token>"


class TokenRedactor(logging.Filter):
    """Replaces ``secret`` in log records of the :data:`FAMILIES` loggers."""

    def __init__(self, secret: str) -> None:
        super().__init__()
        self.secret = secret
        self._loggers: list[logging.Logger] = []

    def redact(self, text: str) -> str:
        return text.replace(self.secret, MASK) if self.secret else text

    def filter(self, record: logging.LogRecord) -> bool:
        try:
            message = record.getMessage()
        except Exception:  # a broken format string: keep the template, drop the args
            message = str(record.msg)
        if self.secret in message:
            record.msg, record.args = self.redact(message), ()
        if record.exc_info and not record.exc_text:
            record.exc_text = logging.Formatter().formatException(record.exc_info)
        if record.exc_text and self.secret in record.exc_text:
            record.exc_text = self.redact(record.exc_text)
        return True

    def install(self) -> None:
        """Attach to every existing logger of the families (and their roots)."""
        manager = logging.Logger.manager
        names = [n for n in list(manager.loggerDict)
                 if any(n == f or n.startswith(f + ".") for f in FAMILIES)]
        for name in {*FAMILIES, *names}:
            logger = logging.getLogger(name)
            if self not in logger.filters:
                logger.addFilter(self)
                self._loggers.append(logger)

    def uninstall(self) -> None:
        for logger in self._loggers:
            logger.removeFilter(self)
        self._loggers.clear()
