"""hvacflex.blas: the one-thread limit holds inside, is restored after (also when nested), gives
the one-thread result from several threads at once, and the process default is set only where
the user set none.

A limit set from a process's main thread (``threadpool_limits``, as the first test does) keeps
OpenBLAS 0.3.3x from taking a later limit set from another thread, so the threaded case runs in
a fresh interpreter."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from typing import Any

import numpy as np
import pytest
import scipy.linalg
from threadpoolctl import threadpool_info, threadpool_limits

from hvacflex.blas import THREAD_COUNT_ENVS, one_blas_thread, prefer_one_thread

pytestmark = pytest.mark.skipif(
    (os.cpu_count() or 1) < 2, reason="one core: OpenBLAS runs one thread whatever is set"
)


def _counts() -> list[int]:
    return [i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"]


def test_one_thread_inside_and_the_count_restored_after() -> None:
    assert scipy.linalg.expm(np.zeros((2, 2)))[0, 0] == 1.0  # scipy's OpenBLAS loaded
    with threadpool_limits(limits=2, user_api="blas"):
        before = _counts()  # 2 each, but a BLAS built for one thread (cvxpy's solvers') stays 1
        assert 2 in before
        with one_blas_thread():
            assert set(_counts()) == {1}
            with one_blas_thread():  # nested: the lock is re-entrant
                assert set(_counts()) == {1}
            assert set(_counts()) == {1}
        assert _counts() == before


THREADED = """
import json, sys, threading
import numpy as np, scipy.linalg
n = int(sys.argv[2])  # 30 or 200: an exponential 1 and 2 threads round apart (by CPU kernel)
a = -np.random.default_rng(1).random((n, n)) * 0.9 * 30 / n
if sys.argv[1] == "reference":
    print(json.dumps(scipy.linalg.expm(a).tolist()))
    raise SystemExit
from hvacflex.blas import one_blas_thread
results, start = [], threading.Barrier(4)
def work():
    start.wait()
    for _ in range(10):
        with one_blas_thread():
            results.append(scipy.linalg.expm(a))
workers = [threading.Thread(target=work) for _ in range(4)]
for w in workers: w.start()
for w in workers: w.join()
default = scipy.linalg.expm(a)
print(json.dumps({"threaded": [r.tolist() for r in results], "default": default.tolist()}))
"""


SIZES = (30, 200)
"""Matrix sizes whose exponential OpenBLAS rounds differently on 1 and 2 threads: 30 where
the kernel threads small products (the machines of earlier CI runs), 200 where it does not
(an AMD EPYC whose kernel computes 30 and 100 on one thread anyway)."""


def _run(argument: str, size: int, **env: str) -> Any:
    inherited = {k: v for k, v in os.environ.items() if k not in THREAD_COUNT_ENVS}
    done = subprocess.run(
        [sys.executable, "-c", THREADED, argument, str(size)],
        env={**inherited, **env},
        capture_output=True,
        text=True,
        check=True,
    )
    return json.loads(done.stdout)


def test_threads_computing_at_once_each_compute_on_one_thread() -> None:
    """Four threads of a two-thread process, each computing under the limit at once, get the
    one-thread result bit for bit (the lock keeps one from restoring another's limit);
    outside the limit the process computes on two threads and differs (at one of
    :data:`SIZES` at least: else the test cannot tell, and says so)."""
    told = []
    for size in SIZES:
        reference = np.array(_run("reference", size, OPENBLAS_NUM_THREADS="1"))
        out = _run("threaded", size, OPENBLAS_NUM_THREADS="2")
        assert len(out["threaded"]) == 40
        assert all(np.array_equal(np.array(r), reference) for r in out["threaded"]), size
        told.append(not np.array_equal(np.array(out["default"]), reference))
    if not any(told):
        pytest.skip(f"this machine's OpenBLAS rounds sizes {SIZES} alike on 1 and 2 threads")


@pytest.mark.parametrize("chosen", [None, *THREAD_COUNT_ENVS])
def test_the_default_is_one_thread_unless_a_count_is_set(
    chosen: str | None, monkeypatch: pytest.MonkeyPatch
) -> None:
    for name in THREAD_COUNT_ENVS:
        monkeypatch.delenv(name, raising=False)
    if chosen is not None:
        monkeypatch.setenv(chosen, "3")
    prefer_one_thread()
    expected = {"OPENBLAS_NUM_THREADS": "1"} if chosen is None else {chosen: "3"}
    assert {n: os.environ[n] for n in THREAD_COUNT_ENVS if n in os.environ} == expected
