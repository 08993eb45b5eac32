"""The compiled monotonic clock (socp_cd.solvers.kernels.clock)."""
import math
import subprocess
import sys
import time

import pytest
from numba import njit

from socp_cd.solvers.kernels import clock


@pytest.mark.skipif(not sys.platform.startswith("linux"),
                    reason="CLOCK_MONOTONIC is time.monotonic's clock on Linux")
def test_the_compiled_clock_reads_the_system_monotonic_clock():
    assert clock.AVAILABLE
    before = time.monotonic()
    now = clock.monotonic()
    after = time.monotonic()
    assert before <= now <= after


def test_the_compiled_clock_advances_with_perf_counter():
    # over 0.1 s, the two clocks advance alike (the best of three tries: a process may be
    # descheduled between two reads)
    gaps = []
    for _ in range(3):
        t0, c0 = time.perf_counter(), clock.monotonic()
        time.sleep(0.1)
        c1, t1 = clock.monotonic(), time.perf_counter()
        gaps.append(abs((c1 - c0) - (t1 - t0)))
    assert min(gaps) < 1e-3


def test_deadlines():
    assert clock.deadline_after(None) == math.inf
    d = clock.deadline_after(0.5)
    assert 0.4 < d - clock.monotonic() <= 0.5
    assert not clock.past(math.inf)
    assert not clock.past(clock.monotonic() + 10.0)
    assert clock.past(clock.monotonic() - 1e-6)


def test_a_kernel_stops_at_its_deadline():
    @njit
    def spin(deadline):
        n = 0
        while not clock.past(deadline):
            n += 1
        return n
    assert spin(clock.deadline_after(-1.0)) == 0        # (compiled here)
    t0 = time.perf_counter()
    assert spin(clock.deadline_after(0.02)) > 0
    assert time.perf_counter() - t0 >= 0.02


def test_kernels_that_read_the_clock_load_from_numba_cache():
    # the clock is emitted by symbol name, not a ctypes pointer (which numba refuses to
    # cache): a new process loads the compiled clock from the cache this one wrote
    clock.monotonic()
    code = ("from socp_cd.solvers.kernels import clock; clock.monotonic(); "
            "print(sum(clock.monotonic.stats.cache_hits.values()), "
            "sum(clock.monotonic.stats.cache_misses.values()))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout.split()
    assert out == ["1", "0"]


def test_without_the_clock_no_deadline_is_set(monkeypatch):
    monkeypatch.setattr(clock, "AVAILABLE", False)
    assert clock.deadline_after(0.0) == math.inf
