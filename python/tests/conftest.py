"""Shared fixtures of the Python tests."""

import signal

import pytest


@pytest.fixture
def sigint_raises():
    """SIGINT raises KeyboardInterrupt during the test, however the suite was started.

    A process started in the background by a non-interactive shell inherits SIGINT as
    ignored, and Python then leaves it ignored (and `_thread.interrupt_main` does
    nothing): the Ctrl-C tests would wait for the whole run instead of testing the stop.
    """
    old = signal.signal(signal.SIGINT, signal.default_int_handler)
    yield
    signal.signal(signal.SIGINT, old)
