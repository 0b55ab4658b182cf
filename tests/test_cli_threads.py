"""The command line computes on one BLAS thread unless the user set a count
(hvacflex.cli_threads): OpenBLAS reads the variable when numpy and scipy load it."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

from hvacflex.cli_threads import BLAS_THREADS_ENV

PROBE = """
import json
import hvacflex.cli, numpy, scipy.linalg
from threadpoolctl import threadpool_info
print(json.dumps([i["num_threads"] for i in threadpool_info() if i["internal_api"] == "openblas"]))
"""


def _openblas_threads(**env: str) -> list[int]:
    environment = {
        k: v for k, v in os.environ.items() if k not in ("OMP_NUM_THREADS", BLAS_THREADS_ENV)
    }
    done = subprocess.run(
        [sys.executable, "-c", PROBE],
        env={**environment, **env},
        capture_output=True,
        text=True,
        check=True,
    )
    counts: list[int] = json.loads(done.stdout)
    return counts


def test_the_command_line_loads_openblas_with_one_thread() -> None:
    counts = _openblas_threads()
    assert counts and counts == [1] * len(counts)


@pytest.mark.skipif((os.cpu_count() or 1) < 2, reason="OpenBLAS caps its threads at the cores")
def test_a_thread_count_the_user_set_is_kept() -> None:
    counts = _openblas_threads(**{BLAS_THREADS_ENV: "2"})
    assert counts and counts == [2] * len(counts)
