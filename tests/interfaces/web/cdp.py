"""The headless-Chromium driver lives in the package (``navstack bench safety`` drives the
page too); the tests import it from here."""

from navstack.benchmarks.cdp import Browser, chromium_binary

__all__ = ["Browser", "chromium_binary"]
