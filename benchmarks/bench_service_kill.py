"""``kill -9`` of ``hvacflex serve`` during writes: is every acknowledged measurement kept?

For each of ``--kills`` rounds on a fresh database (SQLite, or PostgreSQL with ``--postgres
URL``, whose role may create databases): start the server, register ``--buildings``
``room1`` buildings, let each post ``--periods`` measurements without waiting, kill the
server at a random instant (seeded, 0.3–2.5 s after the posts start), count the
acknowledged measurements and those not yet planned at the kill, restart, post each
acknowledged one again with ``wait_s=10`` and count those not answered with their plan of
the promised revision (lost). Bounded: each round ends by itself.

    PYTHONPATH=src python benchmarks/bench_service_kill.py sqlite postgresql \
        --postgres postgresql+psycopg://hvacflex_test:hvacflex_test@127.0.0.1:5432/hvacflex_test
"""

from __future__ import annotations

import argparse
import random
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "service"))

from service_fixtures import (
    START,
    Server,
    drop_postgres_database,
    free_port,
    new_postgres_database,
    operator_key_for,
    registration,
    stored_plans,
)

from hvacflex.service.replay import Client


def one_kill(url: str, buildings: int, periods: int, delay_s: float) -> tuple[int, int, int]:
    """(acknowledged, not planned at the kill, lost) for one kill on database ``url``."""
    server = Server(url, free_port())
    server.start()
    operator = Client(server.url, operator_key_for(url))
    keys: dict[str, str] = {}
    nodes = 0
    for i in range(buildings):
        body = registration(f"k{i}")
        body["building"] = {"name": "room1"}
        registered = operator.call("POST", "/v1/buildings", body)
        keys[f"k{i}"], nodes = registered["key"], len(registered["nodes"])
    acknowledged: list[tuple[str, int, int, dict[str, Any]]] = []
    lock = threading.Lock()

    def post(building_id: str) -> None:
        client = Client(server.url, keys[building_id])
        for k in range(periods):
            stamp = f"{START}T{k // 2:02d}:{30 * (k % 2):02d}"
            body = {"time": stamp, "node_temperatures_degc": [24.0 + 0.1 * k] * nodes}
            try:
                _status, payload = client.call_status(
                    "POST", f"/v1/buildings/{building_id}/measurements", body
                )
            except Exception:
                return
            with lock:
                acknowledged.append((building_id, k, int(payload["revision"]), body))

    threads = [threading.Thread(target=post, args=(b,)) for b in keys]
    for thread in threads:
        thread.start()
    time.sleep(delay_s)
    server.kill9()
    for thread in threads:
        thread.join(timeout=60)
    plans = stored_plans(url)
    unplanned = sum((b, k, r) not in plans for b, k, r, _ in acknowledged)
    server.start()
    lost = 0
    try:
        for building_id, k, revision, body in acknowledged:
            status, plan = Client(server.url, keys[building_id]).call_status(
                "POST", f"/v1/buildings/{building_id}/measurements?wait_s=10", body
            )
            kept = status == 200 and (plan["period"], plan["revision"]) == (k, revision)
            lost += not (kept and plan["trigger"] == "measurement")
    finally:
        server.stop()
    return len(acknowledged), unplanned, lost


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("databases", nargs="+", choices=["sqlite", "postgresql"])
    parser.add_argument("--postgres", default=None, help="PostgreSQL URL (role may CREATEDB)")
    parser.add_argument("--kills", type=int, default=5)
    parser.add_argument("--buildings", type=int, default=4)
    parser.add_argument("--periods", type=int, default=12)
    parser.add_argument("--seed", type=int, default=29)
    parser.add_argument(
        "--quick", action="store_true", help="smoke run at the smallest size (the test suite's)"
    )
    args = parser.parse_args()
    if args.quick:
        args.kills, args.buildings, args.periods = 1, 1, 2
    lost_total = 0
    rng = random.Random(args.seed)
    for kind in args.databases:
        totals = [0, 0, 0]
        for i in range(args.kills):
            if kind == "postgresql":
                if not args.postgres:
                    parser.error("postgresql needs --postgres URL")
                url = new_postgres_database(args.postgres)
            else:
                url = f"sqlite:///{tempfile.mkdtemp(prefix='hvacflex-kill-')}/kill.db"
            try:
                row = one_kill(url, args.buildings, args.periods, rng.uniform(0.3, 2.5))
            finally:
                if kind == "postgresql":
                    drop_postgres_database(args.postgres, url)
            totals = [t + v for t, v in zip(totals, row, strict=True)]
            print(f"{kind} kill {i}: acknowledged {row[0]}, unplanned {row[1]}, lost {row[2]}")
        print(f"{kind} total: acknowledged {totals[0]}, unplanned {totals[1]}, lost {totals[2]}")
        lost_total += totals[2]
    if lost_total:
        raise SystemExit(f"{lost_total} acknowledged measurements lost")
    print("checks passed: no acknowledged measurement lost")


if __name__ == "__main__":
    main()
