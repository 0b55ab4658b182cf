"""The command line computes on one BLAS thread unless the user chose a count
(hvacflex.cli_threads, hvacflex.blas): OpenBLAS reads the variables when numpy and scipy load
it. Each probe is a fresh interpreter without any of the variables but those it is given."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

from hvacflex.blas import THREAD_COUNT_ENVS

PROBE = """
import json
import hvacflex.cli, numpy, scipy.linalg
from threadpoolctl import threadpool_info
print(json.dumps([i["num_threads"] for i in threadpool_info() if i["internal_api"] == "openblas"]))
"""

pytestmark = pytest.mark.skipif(
    (os.cpu_count() or 1) < 2, reason="one core: OpenBLAS runs one thread whatever is set"
)


def _openblas_threads(**env: str) -> list[int]:
    inherited = {k: v for k, v in os.environ.items() if k not in THREAD_COUNT_ENVS}
    done = subprocess.run(
        [sys.executable, "-c", PROBE],
        env={**inherited, **env},
        capture_output=True,
        text=True,
        check=True,
    )
    counts: list[int] = json.loads(done.stdout)
    assert counts, "no OpenBLAS loaded"
    return counts


def test_the_command_line_loads_openblas_with_one_thread() -> None:
    assert _openblas_threads() == [1, 1]  # numpy's and scipy's


@pytest.mark.parametrize("name", THREAD_COUNT_ENVS)
def test_a_thread_count_the_user_set_is_kept(name: str) -> None:
    assert _openblas_threads(**{name: "2"}) == [2, 2]
