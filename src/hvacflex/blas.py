"""BLAS threads: numerics that do not depend on how many there are.

OpenBLAS (numpy's and scipy's wheels) rounds some LAPACK results differently with one thread
and with two: the triangular solves of ``scipy.linalg.expm``'s Padé step on a 34×34 model,
``solve_discrete_are`` on office15's 74×74 one. A model that differs in its last bits gives an
LP with another optimal vertex, so a run would depend on the machine's cores and on
``OMP_NUM_THREADS`` (Dask's workers set 1): a run killed in one process and resumed in another
would not end bit for bit as it began. Two tools:

* :func:`one_blas_thread` runs the model-building numerics on one thread, whatever the process
  has; a lock keeps two threads of one process (the service's request threads) from restoring
  each other's limit mid-computation. (OpenBLAS 0.3.3x ignores a limit set from another thread
  once the main thread has set one itself, e.g. with ``threadpoolctl.threadpool_limits``: a
  program that does so computes such threads' models on its own count.)
* :func:`prefer_one_thread` makes one thread the default of a process before numpy loads
  (:mod:`hvacflex.cli_threads`): a run's matrices are small and hvacflex runs many runs side by
  side in processes, so more threads only spin (≈ 0.1 CPU-s per OpenBLAS loaded).

This module imports neither numpy nor threadpoolctl until :func:`one_blas_thread` is entered.
"""

from __future__ import annotations

import contextlib
import functools
import os
import threading
from collections.abc import Iterator
from typing import Any

THREAD_COUNT_ENVS = ("OPENBLAS_NUM_THREADS", "GOTO_NUM_THREADS", "OMP_NUM_THREADS")
"""The variables OpenBLAS reads for its thread count, first found first."""

_LOCK = threading.RLock()
"""Held while a thread computes under the one-thread limit (re-entrant: nested calls)."""


def prefer_one_thread() -> None:
    """Set ``OPENBLAS_NUM_THREADS=1`` unless one of :data:`THREAD_COUNT_ENVS` is set already.
    Effective only before numpy (or scipy) loads its OpenBLAS."""
    if not any(name in os.environ for name in THREAD_COUNT_ENVS):
        os.environ[THREAD_COUNT_ENVS[0]] = "1"


@functools.cache
def _controller() -> Any:
    """The BLAS/LAPACK libraries loaded now (found once, ≈ 1 ms): the callers of
    :func:`one_blas_thread` import ``scipy.linalg``, so numpy's and scipy's are both loaded; one
    loaded later (cvxpy's solvers bring their own) is not limited, and needs not be."""
    from threadpoolctl import ThreadpoolController

    return ThreadpoolController()


@contextlib.contextmanager
def one_blas_thread() -> Iterator[None]:
    """Run the body with every loaded BLAS on one thread, then restore the counts (≈ 20 µs).

    >>> with one_blas_thread():
    ...     pass
    """
    with _LOCK, _controller().limit(limits=1, user_api="blas"):
        yield
