"""An OpenADR 2.0b VTN (openleadr) to drive an hvacflex service through `serve openadr-ven`.

It accepts one VEN (``--ven-name``), sends it a price event (four 30-min prices from the
next half hour), a demand charge and a dispatch of two periods for ``--building``, prints
the VEN's opt responses and the report values it receives, and stops after
``--duration-s``. It prints the ``--clock-offset`` that maps the next half hour onto
``--service-start`` (the service plans on 2014). Needs ``pip install "hvacflex[openadr]"``.

    python examples/openadr_vtn.py --port 8080 --duration-s 300 &
    HVACFLEX_KEY=… hvacflex serve openadr-ven \\
        --vtn-url http://127.0.0.1:8080/OpenADR2/Simple/2.0b --ven-name site-1 \\
        --url http://127.0.0.1:8000 --building b1 --clock-offset "<printed>"

The building must be registered and measured (a plan) for the dispatch to be opted in:
office5 under ``rmpc`` on 2014-03-03 offers reserve from 15:30 to 17:30.

Against a service in live mode (``hvacflex serve --live``: real dates) pass ``--live``: the
events are for the next half hour of today and the printed offset is ``0min`` (the VEN's
default). Register the building with today's date as its scenario start and post its
measurement of the current period first.
"""

from __future__ import annotations

import argparse
import asyncio
from datetime import UTC, datetime, timedelta
from typing import Any

from openleadr import OpenADRServer

HALF_HOUR = timedelta(minutes=30)
PRICES_SGD_PER_KWH = [0.10, 0.25, 0.40, 0.15]
DEMAND_CHARGE_SGD_PER_KW = 3.5
DISPATCH_KW = 5.0


def next_half_hour(now: datetime) -> datetime:
    """The first 30-min boundary after ``now`` (UTC)."""
    floor = now.replace(minute=30 if now.minute >= 30 else 0, second=0, microsecond=0)
    return floor + HALF_HOUR


def events(start: datetime, building: str) -> list[dict[str, Any]]:
    """The events sent: prices, a demand charge and a dispatch of ``building``."""

    def intervals(first: datetime, payloads: list[float]) -> list[dict[str, Any]]:
        return [
            {"dtstart": first + j * HALF_HOUR, "duration": HALF_HOUR, "signal_payload": p}
            for j, p in enumerate(payloads)
        ]

    return [
        {
            "signal_name": "ELECTRICITY_PRICE",
            "signal_type": "price",
            "intervals": intervals(start, PRICES_SGD_PER_KWH),
        },
        {
            "signal_name": "DEMAND_CHARGE",
            "signal_type": "price",
            "intervals": [
                {
                    "dtstart": start,
                    "duration": 4 * HALF_HOUR,
                    "signal_payload": DEMAND_CHARGE_SGD_PER_KW,
                }
            ],
        },
        {
            "signal_name": "LOAD_DISPATCH",
            "signal_type": "delta",
            "intervals": intervals(start + HALF_HOUR, [DISPATCH_KW, DISPATCH_KW]),
            "targets": [{"resource_id": building}],
        },
    ]


async def serve(args: argparse.Namespace) -> None:
    the_ven_id, registration_id = "ven-1", "reg-1"
    registered: list[str] = []

    def on_create_party_registration(info: dict[str, Any]) -> tuple[str, str] | bool:
        if info.get("ven_name") != args.ven_name:
            return False
        registered.append(info["ven_name"])
        print(f"VEN {info['ven_name']} registered as {the_ven_id}", flush=True)
        return the_ven_id, registration_id

    def ven_lookup(ven_id: str) -> dict[str, Any]:  # openleadr calls it with ven_id=…
        if ven_id != the_ven_id or not registered:
            return {}
        return {"ven_id": ven_id, "ven_name": args.ven_name, "registration_id": registration_id}

    def on_register_report(report: dict[str, Any]) -> list[tuple[str, Any, timedelta]]:
        requests = []
        for description in report["report_descriptions"]:
            r_id = description["r_id"]

            def show(values: list[tuple[datetime, float]], r_id: str = r_id) -> None:
                first = values[0] if values else None
                print(f"report {r_id}: {len(values)} values, first {first}", flush=True)

            requests.append((r_id, show, timedelta(seconds=args.report_s)))
        return requests

    def on_opt(ven_id: str, event_id: str, opt_type: str) -> None:
        print(f"event {event_id}: {opt_type}", flush=True)

    server = OpenADRServer(
        vtn_id="EXAMPLE-VTN",
        http_host="127.0.0.1",
        http_port=args.port,
        requested_poll_freq=timedelta(seconds=2),
        ven_lookup=ven_lookup,
        show_fingerprint=False,
    )
    server.add_handler("on_create_party_registration", on_create_party_registration)
    server.add_handler("on_register_report", on_register_report)
    start = next_half_hour(datetime.now(UTC))
    offset_min = 0 if args.live else int((args.service_start - start).total_seconds() // 60)
    for event in events(start, args.building):
        server.add_event(ven_id=the_ven_id, callback=on_opt, **event)
    await server.run()
    print(f"VTN on http://127.0.0.1:{args.port}/OpenADR2/Simple/2.0b", flush=True)
    print(f"events from {start.isoformat()}; pass --clock-offset '{offset_min}min'", flush=True)
    await asyncio.sleep(args.duration_s)
    await server.stop()
    print(f"stopped after {args.duration_s:g} s; {len(registered)} VEN registrations", flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--port", type=int, default=8080)
    parser.add_argument("--ven-name", default="site-1")
    parser.add_argument("--building", default="b1")
    parser.add_argument(
        "--service-start",
        type=datetime.fromisoformat,
        default=datetime.fromisoformat("2014-03-03T15:30+08:00"),
        help="Service time the next half hour maps to.",
    )
    parser.add_argument(
        "--live",
        action="store_true",
        help="The service is in live mode (hvacflex serve --live): no clock offset.",
    )
    parser.add_argument("--duration-s", type=float, default=300.0)
    parser.add_argument("--report-s", type=float, default=10.0, help="Report sampling [s].")
    asyncio.run(serve(parser.parse_args()))


if __name__ == "__main__":
    main()
