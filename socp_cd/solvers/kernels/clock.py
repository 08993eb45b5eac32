"""A monotonic clock that compiled kernels can read.

numba's nopython mode has no ``time`` module, so a compiled loop used to be
unable to honour a time limit: its callers ran it in chunks and read the clock
in Python between them, or declined time-limited calls whose worst-case work
might overrun the limit.  :func:`monotonic` reads the operating system's
monotonic clock (POSIX ``clock_gettime``, ~20 ns through the vDSO on Linux) from
compiled code and from Python alike, so a kernel can stop at a *deadline*: a
time on this clock (:func:`deadline_after`), checked where the loop can stop
cleanly (after an outer iteration, between blocks of sweeps).

The call is emitted by name (an LLVM declaration of ``clock_gettime`` resolved
when the code is loaded), not through a ctypes pointer, so kernels that use it
stay in numba's on-disk cache.  On a platform without ``clock_gettime``
(:data:`AVAILABLE` False: Windows, 32-bit builds) the compiled clock reads ``-inf``, no
deadline is ever reached, and callers keep their bounds on the work of a
time-limited call.
"""
from __future__ import annotations

import math
import struct
import sys

import numpy as np
from llvmlite import ir
from numba import njit, types
from numba.core import cgutils
from numba.extending import intrinsic

#: ``CLOCK_MONOTONIC``'s id in ``<time.h>`` by platform (None: no ``clock_gettime``), on
#: 64-bit builds only (the intrinsic reads ``struct timespec`` as two 64-bit integers).
#: numba does not recompile a cached kernel when a function it calls changes: after an edit
#: here, clear the caches (``make clean-cache``)
_CLOCK_IDS = {"linux": 1, "darwin": 6, "freebsd": 4}
_CLOCK_ID = (next((v for k, v in _CLOCK_IDS.items() if sys.platform.startswith(k)), None)
             if struct.calcsize("P") == 8 else None)
#: whether the compiled clock reads a real clock on this platform
AVAILABLE = _CLOCK_ID is not None


@intrinsic
def _clock_seconds(typingctx):
    """``clock_gettime(CLOCK_MONOTONIC)`` in seconds (float64); ``-inf`` without it."""
    def codegen(context, builder, signature, args):
        f64 = ir.DoubleType()
        if _CLOCK_ID is None:
            return ir.Constant(f64, -math.inf)
        i64, i32 = ir.IntType(64), ir.IntType(32)
        timespec = ir.LiteralStructType([i64, i64])     # (tv_sec, tv_nsec): 64-bit ABIs
        fn = cgutils.get_or_insert_function(
            builder.module, ir.FunctionType(i32, [i32, timespec.as_pointer()]), "clock_gettime")
        ts = cgutils.alloca_once(builder, timespec)
        builder.call(fn, [ir.Constant(i32, _CLOCK_ID), ts])
        sec = builder.sitofp(builder.load(cgutils.gep_inbounds(builder, ts, 0, 0)), f64)
        nsec = builder.sitofp(builder.load(cgutils.gep_inbounds(builder, ts, 0, 1)), f64)
        return builder.fadd(sec, builder.fmul(nsec, ir.Constant(f64, 1e-9)))
    return types.float64(), codegen


@njit(cache=True)
def monotonic():
    """Seconds on the monotonic clock (any origin; ``-inf`` when :data:`AVAILABLE` is False).

    Callable from compiled kernels and from Python (~0.1 µs there, the dispatch)."""
    return _clock_seconds()


@njit(cache=True)
def past(deadline):
    """Whether the clock has passed ``deadline`` (``inf``: never; the clock is not read)."""
    return deadline < np.inf and _clock_seconds() > deadline


def deadline_after(seconds) -> float:
    """The deadline ``seconds`` from now on :func:`monotonic`'s clock (``inf`` for None,
    and when :data:`AVAILABLE` is False)."""
    if seconds is None or not AVAILABLE:
        return math.inf
    return monotonic() + float(seconds)


__all__ = ["AVAILABLE", "monotonic", "past", "deadline_after"]
