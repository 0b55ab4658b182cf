"""One BLAS thread for the ``hvacflex`` command line, unless the user chose a count.

Imported by :mod:`hvacflex.cli` before anything that loads numpy: OpenBLAS reads its thread
count when it loads (:func:`hvacflex.blas.prefer_one_thread`; why one thread: :mod:`hvacflex.blas`).
Importing it sets ``OPENBLAS_NUM_THREADS=1`` in ``os.environ`` unless ``OPENBLAS_NUM_THREADS``,
``GOTO_NUM_THREADS`` or ``OMP_NUM_THREADS`` is set; processes the command starts inherit it.
"""

from __future__ import annotations

from hvacflex.blas import prefer_one_thread

prefer_one_thread()
