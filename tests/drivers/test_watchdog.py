"""The link watchdog's transitions on an explicit clock."""

from __future__ import annotations

import pytest

from navstack.drivers.watchdog import LinkWatchdog


def test_lost_after_timeout_and_restored_after_a_streak() -> None:
    w = LinkWatchdog(timeout=0.3, restore_count=3)
    w.start(0.0)
    for k in range(10):
        w.feed(0.05 * k)
        assert w.check(0.05 * k) is None
    assert w.check(0.75) is None  # 0.3 s after the last packet at 0.45: not yet
    assert w.check(0.76) == "lost" and w.lost and w.lost_at == 0.76
    assert w.check(0.8) is None
    w.feed(2.0)
    assert w.check(2.0) is None  # one packet is not enough
    w.feed(2.05)
    w.feed(2.1)
    assert w.check(2.1) == "restored" and not w.lost and w.losses == 1


def test_a_link_that_never_spoke_is_lost() -> None:
    w = LinkWatchdog(timeout=0.5)
    w.start(10.0)
    assert w.check(10.4) is None
    assert w.check(10.6) == "lost"


def test_streak_resets_when_silence_returns() -> None:
    w = LinkWatchdog(timeout=0.3, restore_count=2)
    w.start(0.0)
    assert w.check(0.4) == "lost"
    w.feed(1.0)
    assert w.check(1.5) is None  # one packet, then silence again
    w.feed(2.0)
    assert w.check(2.0) is None  # the earlier packet does not count
    w.feed(2.1)
    assert w.check(2.1) == "restored"


def test_rejects_bad_parameters() -> None:
    with pytest.raises(ValueError, match="timeout must be > 0"):
        LinkWatchdog(timeout=0.0)
    with pytest.raises(ValueError, match="restore_count"):
        LinkWatchdog(restore_count=0)
