"""Each building's latest plan in memory (``hvacflex.service.plan_cache``): a later plan is
never replaced by an earlier one, a fill from the database that raced with a failed job is
dropped, and through the app: a plan read after a new plan came back is that plan (never the
one before), byte for byte the database's answer, and answered without reading a plan row —
on every database of ``make_db_url``."""

from __future__ import annotations

import json
import time
from collections.abc import Callable, Iterator
from typing import Any

import pytest
from fastapi.testclient import TestClient
from service_fixtures import START, app_with_building
from sqlalchemy import event

from hvacflex.service.plan_cache import NO_PLAN, CachedPlan, LatestPlans, plan_answer
from hvacflex.service.schemas import Envelope, Plan


def _stub_plan(period: int, revision: int) -> dict[str, Any]:
    """A plan payload the route's model accepts (every field it requires)."""
    fields: dict[str, Any] = {}
    for name, field in Plan.model_fields.items():
        if field.is_required():
            fields[name] = None
    fields.update(
        building_id="b1",
        period=period,
        revision=revision,
        time=f"{START}T00:00:00+08:00",
        trigger="measurement",
        zones=["z1"],
        status="optimal",
        fallback=False,
    )
    return fields


def _valid_stub(period: int, revision: int) -> dict[str, Any]:
    """:func:`_stub_plan` completed from the model's own validation errors (each missing
    or wrongly typed field set to a value of its type)."""
    from pydantic import ValidationError

    plan = _stub_plan(period, revision)
    for _ in range(100):
        try:
            Plan(**plan)
            return plan
        except ValidationError as exc:
            for error in exc.errors():
                name = str(error["loc"][0])
                kind = error["type"]
                plan[name] = (
                    0.0
                    if kind.startswith("float")
                    else 0
                    if kind.startswith("int")
                    else False
                    if kind.startswith("bool")
                    else []
                    if kind.startswith("list")
                    else "x"
                )
    raise AssertionError("no valid stub plan")


def test_a_later_plan_is_never_replaced_by_an_earlier_one() -> None:
    plans = LatestPlans()
    assert plans.get("b1") is None
    plans.offer("b1", _valid_stub(3, 2))
    plans.offer("b1", _valid_stub(3, 1))  # an earlier revision, come back late
    plans.offer("b1", _valid_stub(2, 5))  # an earlier period
    entry = plans.get("b1")
    assert isinstance(entry, CachedPlan) and entry.order == (3, 2)
    assert json.loads(entry.body)["payload"]["revision"] == 2
    plans.offer("b1", _valid_stub(3, 3))  # a new revision of the same period (activation)
    plans.offer("b1", _valid_stub(4, 1))
    entry = plans.get("b1")
    assert isinstance(entry, CachedPlan) and entry.order == (4, 1)


def test_a_fill_keeps_no_older_plan_and_none_after_a_failed_job() -> None:
    plans = LatestPlans()
    token = plans.token("b1")
    plans.fill("b1", NO_PLAN, token)
    assert plans.get("b1") is NO_PLAN
    plans.offer("b1", _valid_stub(0, 1))  # the first plan replaces "no plan yet"
    plans.fill("b1", NO_PLAN, plans.token("b1"))  # read before it was committed
    plans.fill("b1", plan_answer(_valid_stub(0, 1)), plans.token("b1"))
    entry = plans.get("b1")
    assert isinstance(entry, CachedPlan) and entry.order == (0, 1)
    token = plans.token("b1")  # a read of the database starts …
    plans.forget("b1")  # … a job fails (its plan may be committed) …
    plans.fill("b1", plan_answer(_valid_stub(0, 1)), token)  # … the read ends: dropped
    assert plans.get("b1") is None
    plans.fill("b1", plan_answer(_valid_stub(1, 1)), plans.token("b1"))
    entry = plans.get("b1")
    assert isinstance(entry, CachedPlan) and entry.order == (1, 1)


@pytest.fixture
def served(make_db_url: Callable[[str], str]) -> Iterator[tuple[TestClient, dict[str, str], Any]]:
    """A fresh app with building ``b1`` (``rmpc``, office5, one day); the keys by name."""
    client, keys, _, app = app_with_building(make_db_url("cache"), "b1")
    yield client, keys, app
    client.close()
    app.state.planner.shutdown()
    app.state.engine.dispose()


def _database_answer(app: Any, building_id: str) -> bytes:
    """The latest plan's answer as the route made it from the database before."""
    with app.state.sessions() as session:
        plan = app.state.runtime.latest_plan(session, building_id)
    return Envelope(status=200, message="ok", payload=Plan(**plan)).model_dump_json().encode()


def _until_keys_in_memory(client: TestClient, app: Any, keys: dict[str, str]) -> None:
    """Read until every key is answered from memory (the revocations polled lately)."""
    for _ in range(200):
        if all(app.state.auth.verified_keys.get(key) for key in keys.values()):
            return
        for key in keys.values():
            client.get("/v1/buildings/b1/plan", headers={"X-API-Key": key})
        time.sleep(0.02)
    raise AssertionError("the keys are not answered from memory")


def test_a_new_plan_is_read_at_once_as_the_database_answers_it(
    served: tuple[TestClient, dict[str, str], Any],
) -> None:
    client, keys, app = served
    nodes = len(
        client.get("/v1/buildings/b1", headers={"X-API-Key": keys["b1"]}).json()["payload"]["nodes"]
    )
    app.state.auth.verified_keys.max_age_s = 60.0  # keys: test_service_keys.py; plans here
    statements: list[str] = []
    event.listen(app.state.engine, "before_cursor_execute", lambda *a: statements.append(str(a[2])))
    for k in range(3):
        body = {
            "time": f"{START}T00:{30 * k:02d}" if k < 2 else f"{START}T01:00",
            "node_temperatures_degc": [24.0 + 0.2 * k] * nodes,
        }
        for who in ("b1", "operator"):  # a read before the plan: a building with no plan
            before = client.get("/v1/buildings/b1/plan", headers={"X-API-Key": keys[who]})
            if k == 0:
                assert before.status_code == 404 and before.json()["message"] == "no plan yet"
        posted = client.post(
            "/v1/buildings/b1/measurements?wait_s=10",
            json=body,
            headers={"X-API-Key": keys["b1"]},
        )
        assert posted.status_code == 200, posted.text
        _until_keys_in_memory(client, app, keys)
        expected = _database_answer(app, "b1")
        statements.clear()
        for who in ("b1", "operator", "b1"):
            read = client.get("/v1/buildings/b1/plan", headers={"X-API-Key": keys[who]})
            assert read.status_code == 200
            assert read.json()["payload"]["period"] == k  # never the plan before
            assert read.json()["payload"]["revision"] == posted.json()["payload"]["revision"]
            assert read.content == expected
        same_period = client.get(
            f"/v1/buildings/b1/plan?period={k}", headers={"X-API-Key": keys["b1"]}
        )
        assert same_period.content == read.content
        read_rows = [s for s in statements if "FROM plans" in s or "api_keys.key_id" in s]
        assert not read_rows, read_rows
    earlier = client.get("/v1/buildings/b1/plan?period=0", headers={"X-API-Key": keys["b1"]})
    assert earlier.status_code == 200 and earlier.json()["payload"]["period"] == 0
    other = client.get("/v1/buildings/b2/plan", headers={"X-API-Key": keys["b1"]})
    assert other.status_code == 403  # a building key, another building: from memory too
    unknown = client.get("/v1/buildings/nope/plan", headers={"X-API-Key": keys["operator"]})
    assert unknown.status_code == 404 and "no such building" in unknown.json()["message"]
