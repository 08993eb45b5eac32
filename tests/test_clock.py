"""The compiled monotonic clock (socp_cd.solvers.kernels.clock)."""
import math
import time
import warnings

import numpy as np
from numba import njit

from socp_cd.solvers.kernels import clock


def test_the_compiled_clock_reads_the_system_monotonic_clock():
    assert clock.AVAILABLE
    # on Linux, CLOCK_MONOTONIC is time.monotonic's clock: the two agree to call overhead
    before = time.monotonic()
    now = clock.monotonic()
    after = time.monotonic()
    assert before - 1e-3 <= now <= after + 1e-3
    # and it advances at the rate of time.perf_counter
    t0, c0 = time.perf_counter(), clock.monotonic()
    time.sleep(0.05)
    t1, c1 = time.perf_counter(), clock.monotonic()
    assert abs((c1 - c0) - (t1 - t0)) < 5e-3


def test_deadlines():
    assert clock.deadline_after(None) == math.inf
    d = clock.deadline_after(0.5)
    assert 0.49 < d - clock.monotonic() <= 0.5
    assert not clock.past(math.inf)
    assert not clock.past(clock.monotonic() + 10.0)
    assert clock.past(clock.monotonic() - 1e-6)


def test_a_kernel_stops_at_its_deadline_and_stays_cacheable():
    @njit
    def spin(deadline):
        n = 0
        while not clock.past(deadline):
            n += 1
        return n
    assert spin(clock.deadline_after(-1.0)) == 0        # (compiled here)
    t0 = time.perf_counter()
    assert spin(clock.deadline_after(0.02)) > 0
    assert 0.02 <= time.perf_counter() - t0 < 1.0
    # the clock is emitted by symbol name, not a ctypes pointer: numba caches a kernel
    # that reads it (a pointer would make it refuse, with a NumbaWarning)
    with warnings.catch_warnings():
        warnings.simplefilter("error")

        @njit(cache=True)
        def cached():
            return clock.monotonic()
        assert np.isfinite(cached())
    assert cached._cache._cache_path is not None


def test_without_the_clock_no_deadline_is_set(monkeypatch):
    monkeypatch.setattr(clock, "AVAILABLE", False)
    assert clock.deadline_after(0.0) == math.inf
