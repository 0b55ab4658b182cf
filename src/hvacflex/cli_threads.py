"""One BLAS thread for the ``hvacflex`` command line, unless the user chose otherwise.

Imported by :mod:`hvacflex.cli` before anything that loads numpy: OpenBLAS reads
``OPENBLAS_NUM_THREADS`` when it loads. A run's matrices are small (tens of states, LPs that
HiGHS solves on one thread), so BLAS threads do not make a period faster; they only spin —
each OpenBLAS that numpy and scipy load keeps its idle threads busy for ≈ 0.1 s, 0.2 CPU-s
of every start (docs/reference/performance.md). hvacflex runs many runs side by side in
processes instead (Dask workers, which set one thread themselves), so a command-line run
computes with the same thread count as a worker's. A value the user set is kept.
"""

from __future__ import annotations

import os

BLAS_THREADS_ENV = "OPENBLAS_NUM_THREADS"
"""The variable OpenBLAS (numpy's and scipy's wheels) reads for its thread count."""

os.environ.setdefault(BLAS_THREADS_ENV, "1")
