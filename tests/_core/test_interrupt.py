"""`interrupts_deferred_now`: whether a block that a stop must not cut short is
running, in this thread or another (the command line's watchdog waits for it)."""

from __future__ import annotations

import threading

import pytest

from pointatlas._core import interrupts_deferred, interrupts_deferred_now


def test_deferred_blocks_are_seen_while_they_run_in_any_thread():
    assert not interrupts_deferred_now()
    with interrupts_deferred():
        assert interrupts_deferred_now()
        with interrupts_deferred():  # nested
            assert interrupts_deferred_now()
        assert interrupts_deferred_now()
    assert not interrupts_deferred_now()
    inside, leave, seen = threading.Event(), threading.Event(), []

    def other():
        with interrupts_deferred():
            inside.set()
            leave.wait(30)

    worker = threading.Thread(target=other)
    worker.start()
    inside.wait(30)
    seen.append(interrupts_deferred_now())
    leave.set()
    worker.join(30)
    assert seen == [True] and not interrupts_deferred_now()
    with pytest.raises(RuntimeError), interrupts_deferred():
        raise RuntimeError("a block that fails")
    assert not interrupts_deferred_now()
