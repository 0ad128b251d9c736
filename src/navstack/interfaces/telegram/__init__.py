"""Telegram bot for a live stack: location -> nearest target, e-stop, progress replies;
a chat-id whitelist is required.  Tested against :class:`fake_api.FakeBotApi`, a local Bot
API server.  See ``docs/operator_interfaces.md``."""

from navstack.interfaces.telegram.bot import TelegramBot, TelegramBotError, TelegramParams
from navstack.interfaces.telegram.targets import Target, load_targets, nearest_target

__all__ = ["Target", "TelegramBot", "TelegramBotError", "TelegramParams", "load_targets",
           "nearest_target"]
