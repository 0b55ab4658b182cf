"""``hvacflex serve``: the live service, its API keys, the replay client and the OpenADR VEN."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import typer

from hvacflex.cli_help import check_days, exit_on_error, run_summary_line, scenario_config

serve_app = typer.Typer(
    rich_markup_mode=None,
    help="The live service: `hvacflex serve` runs it; `key` manages its keys; `replay` uses it.",
    invoke_without_command=True,
)
serve_key_app = typer.Typer(
    rich_markup_mode=None, help="API keys of the service.", no_args_is_help=True
)
serve_app.add_typer(serve_key_app, name="key")

DB_ENV = "HVACFLEX_DB"
DEFAULT_SERVE_DB = "sqlite:///hvacflex-service.db"
_DB_HELP = (
    "Database URL: sqlite:///FILE (default sqlite:///hvacflex-service.db) or "
    "postgresql+psycopg://USER@HOST/DB; given to `serve` or to a subcommand."
)
_SUB_DB_OPTION = typer.Option(None, "--db", help=_DB_HELP, show_default=False)
_PLAN_PROCESSES_OPTION = typer.Option(
    2,
    "--plan-processes",
    min=0,
    max=64,
    help="Worker processes that make the plans (each building pinned to one), so requests "
    "never wait behind a solve; 0: threads of the server process.",
)
_PLAN_NICENESS_OPTION = typer.Option(
    19,
    "--plan-niceness",
    min=0,
    max=19,
    help="How much lower the planning processes' CPU priority is than the server's (nice "
    "0-19), so that requests get the cores first.",
)


def _serve_db(ctx: typer.Context, db: str | None) -> str:
    """The database URL: this command's --db, else the one given to `serve`, else
    $HVACFLEX_DB, else the default SQLite file."""
    if db is not None:
        return db
    given = ctx.find_object(dict)
    return str((given or {}).get("serve_db") or DEFAULT_SERVE_DB)


@serve_app.callback()
def serve(
    ctx: typer.Context,
    db: str | None = typer.Option(None, "--db", envvar=DB_ENV, help=_DB_HELP, show_default=False),
    host: str = typer.Option("127.0.0.1", help="Address to listen on."),
    port: int = typer.Option(8000, min=1, max=65535, help="Port to listen on."),
    wall_clock: bool = typer.Option(
        False, help="Also plan at each wall-clock 30-min boundary (else: POST /v1/clock)."
    ),
    live: bool = typer.Option(
        False,
        help="Live mode: buildings plan on real dates (typical-year weather, the prices of "
        "the same weekday nearest the date in the price data, unless posted).",
    ),
    ssl_certfile: Path | None = typer.Option(  # noqa: B008
        None, help="TLS: the server's certificate (chain), PEM; with --ssl-keyfile."
    ),
    ssl_keyfile: Path | None = typer.Option(  # noqa: B008
        None, help="TLS: the certificate's private key, PEM."
    ),
    ssl_min_version: str = typer.Option(
        "1.2", "--ssl-min-version", help="TLS: the oldest TLS version accepted, 1.2 or 1.3."
    ),
    insecure_http: bool = typer.Option(
        False,
        "--insecure-http",
        help="Allow plain HTTP on an address other than loopback (API keys travel in clear): "
        "only behind a TLS-terminating proxy.",
    ),
    stale_after_s: float = typer.Option(
        3600.0,
        help="A building with no measurement for this many seconds is stale: its plan "
        "is left out of the aggregate bid.",
    ),
    log_level: str = typer.Option("info", help="JSON log level: debug, info, warning, error."),
    register_limit: str = typer.Option(
        "10/3600",
        "--register-limit",
        help="Each key's budget of POST /v1/buildings: N/SECONDS (N requests per SECONDS).",
    ),
    clock_limit: str = typer.Option(
        "1/10", "--clock-limit", help="Each key's budget of POST /v1/clock: N/SECONDS."
    ),
    plan_processes: int = _PLAN_PROCESSES_OPTION,
    plan_niceness: int = _PLAN_NICENESS_OPTION,
) -> None:
    """Run the HTTP service (API under /v1, OpenAPI at /v1/openapi.json); prints its URL
    and logs one JSON line per request on standard error."""
    ctx.ensure_object(dict)["serve_db"] = db
    if ctx.invoked_subcommand is not None:
        return
    import sys

    from hvacflex.errors import HvacflexError, require_extra

    try:
        require_extra("service", "hvacflex serve")
    except HvacflexError as exc:
        raise exit_on_error(exc) from None
    from hvacflex.service.app import create_app
    from hvacflex.service.operations import (
        check_listen_address,
        check_plain_http,
        check_tls,
        service_url,
        tls_minimum_version,
    )

    try:
        _check_log_and_staleness(log_level, stale_after_s)
        route_limits = _route_limits(register_limit, clock_limit)
        tls = check_tls(ssl_certfile, ssl_keyfile)
        minimum_tls = tls_minimum_version(ssl_min_version)
        check_listen_address(host, port)
        check_plain_http(host, tls, insecure_http)
        service = create_app(
            _serve_db(ctx, db),
            wall_clock=wall_clock,
            stale_after_s=stale_after_s,
            live=live,
            route_limits=route_limits,
            plan_processes=plan_processes,
            plan_niceness=plan_niceness,
            freeze_heap=True,
        )
    except HvacflexError as exc:
        raise exit_on_error(exc) from None
    mode = "; live mode: real dates" if live else ""
    typer.echo(f"hvacflex service on {service_url(host, port, tls)} (API under /v1){mode}")
    sys.stdout.flush()  # the URL reaches a pipe (a supervisor, a test) before the first request
    _run_server(
        service,
        host,
        port,
        (ssl_certfile, ssl_keyfile) if tls else None,
        minimum_tls,
        log_level,
    )


def _route_limits(register_limit: str, clock_limit: str) -> dict[str, Any]:
    """Each key's budgets on the costly routes, from ``--register-limit`` and
    ``--clock-limit``.

    Raises
    ------
    InputError : either is not two positive numbers joined by ``/`` (naming the option).
    """
    from hvacflex.service.keys import CLOCK_ROUTE, REGISTER_ROUTE, parse_route_limit

    return {
        REGISTER_ROUTE: parse_route_limit(register_limit, "--register-limit"),
        CLOCK_ROUTE: parse_route_limit(clock_limit, "--clock-limit"),
    }


def _check_log_and_staleness(log_level: str, stale_after_s: float) -> None:
    """Refuse an unknown ``--log-level`` or a ``--stale-after-s`` that is not > 0 s.

    Raises
    ------
    InputError : naming the option.
    """
    from hvacflex.errors import InputError

    levels = ("debug", "info", "warning", "error")
    if log_level.lower() not in levels:
        raise InputError(
            "unknown level",
            field="--log-level",
            value=log_level,
            hint=f"use one of {', '.join(levels)}",
        )
    if not math.isfinite(stale_after_s) or stale_after_s <= 0:
        raise InputError(
            "must be a finite number of seconds > 0",
            field="--stale-after-s",
            value=stale_after_s,
        )


def _run_server(
    service: Any,
    host: str,
    port: int,
    tls_files: tuple[Path | None, Path | None] | None,
    minimum_tls: Any,
    log_level: str,
) -> None:
    """Serve ``service`` with uvicorn until stopped; over TLS (certificate, key) no older
    than ``minimum_tls`` (an :class:`ssl.TLSVersion`). A server that could not start exits
    3, as ``uvicorn.run`` does."""
    import uvicorn

    from hvacflex.service.operations import json_log_config

    certfile, keyfile = tls_files if tls_files is not None else (None, None)
    config = uvicorn.Config(
        service,
        host=host,
        port=port,
        ssl_certfile=None if certfile is None else str(certfile),
        ssl_keyfile=None if keyfile is None else str(keyfile),
        log_config=json_log_config(log_level.upper()),
        access_log=False,
    )
    config.load()  # builds the server's SSL context: hardened here, before it serves
    if config.ssl is not None:
        config.ssl.minimum_version = minimum_tls
    server = uvicorn.Server(config)
    try:
        server.run()
    except KeyboardInterrupt:
        pass
    if not server.started:
        raise typer.Exit(3)


def _key_sessions(ctx: typer.Context, db: str | None) -> Any:
    """Sessions on the service's database (opened and migrated, errors → exit 2)."""
    from hvacflex.errors import HvacflexError
    from hvacflex.service.db import open_database, session_factory

    try:
        return session_factory(open_database(_serve_db(ctx, db)))
    except HvacflexError as exc:
        raise exit_on_error(exc) from None


@serve_key_app.callback()
def serve_key() -> None:
    """API keys of the service (needs the service extra: its database)."""
    from hvacflex.errors import HvacflexError, require_extra

    try:
        require_extra("service", "hvacflex serve key")
    except HvacflexError as exc:
        raise exit_on_error(exc) from None


@serve_key_app.command("create")
def serve_key_create(
    ctx: typer.Context,
    role: str = typer.Option(..., help="operator or building."),
    building: str | None = typer.Option(None, help="The building of a building key."),
    key_file: Path | None = typer.Option(  # noqa: B008
        None, help="Also write the key to this new file (mode 0600; for --key-file)."
    ),
    db: str | None = _SUB_DB_OPTION,
) -> None:
    """Create an API key; the key alone is the last line printed (only its hash is stored)."""
    from hvacflex.errors import HvacflexError
    from hvacflex.service.keys import create_key, write_key_file

    sessions = _key_sessions(ctx, db)
    try:
        with sessions() as session, session.begin():
            key = create_key(session, role, building)
            if key_file is not None:
                write_key_file(key_file, key)
    except HvacflexError as exc:
        raise exit_on_error(exc) from None
    where = f" (also in {key_file})" if key_file is not None else ""
    typer.echo(f"created {role} key {key.split('_')[1]}{where}; it is shown once:")
    typer.echo(key)


@serve_key_app.command("list")
def serve_key_list(ctx: typer.Context, db: str | None = _SUB_DB_OPTION) -> None:
    """One key per line: key id, role, building (- for none), created (UTC), revoked."""
    from hvacflex.service.keys import list_keys

    with _key_sessions(ctx, db)() as session:
        keys = list_keys(session)
    for k in keys:
        created = k.created_at.strftime("%Y-%m-%dT%H:%M:%SZ")
        typer.echo(
            f"{k.key_id} {k.role} {k.building_id or '-'} {created} "
            f"{'revoked' if k.revoked else 'active'}"
        )


@serve_key_app.command("revoke")
def serve_key_revoke(
    ctx: typer.Context,
    key_id: str = typer.Argument(..., help="The key's id (the 16 hex digits after hvf_)."),
    db: str | None = _SUB_DB_OPTION,
) -> None:
    """Revoke a key: a running service refuses it (401) from its next request on
    (plan reads, which check keys in memory: within 0.5 s)."""
    from hvacflex.errors import HvacflexError
    from hvacflex.service.keys import revoke_key

    sessions = _key_sessions(ctx, db)
    try:
        with sessions() as session, session.begin():
            was = revoke_key(session, key_id)
    except HvacflexError as exc:
        raise exit_on_error(exc) from None
    typer.echo(f"key {key_id} {'was already' if was else 'is now'} revoked")


@serve_app.command("replay")
def serve_replay(
    url: str = typer.Option(..., help="The service, e.g. http://127.0.0.1:8000."),
    key_file: Path | None = typer.Option(  # noqa: B008
        None, help="File holding an operator key (else $HVACFLEX_KEY); registers the building."
    ),
    scenario: str = typer.Option("rmpc", help="Preset of the scenario."),
    config: Path | None = typer.Option(None, help="Scenario TOML file (overrides --scenario)."),  # noqa: B008
    start: str | None = typer.Option(None, help="First day, e.g. 2014-03-03."),
    days: float | None = typer.Option(None, help="Number of days.", callback=check_days),
    out: Path = typer.Option(Path("results/replay"), help="Output folder."),  # noqa: B008
    building_id: str = typer.Option("replay", "--building", help="Id to register under."),
) -> None:
    """Play the nonlinear plant as a building over HTTP; writes the files of `simulate`.
    The operator key comes from $HVACFLEX_KEY or --key-file, never the command line."""
    from hvacflex.errors import HvacflexError
    from hvacflex.results import RESULTS_FILENAME
    from hvacflex.service.replay import check_service_url, read_key, replay

    try:
        check_service_url(url)
        key = read_key(key_file)
        cfg = scenario_config(scenario, config, start, days)
        result = replay(url, key, cfg, out, building_id=building_id)
    except HvacflexError as exc:
        raise exit_on_error(exc) from None
    typer.echo(run_summary_line(cfg.name, result.summary, result.out_dir / RESULTS_FILENAME))


@serve_app.command("openadr-ven")
def serve_openadr_ven(
    vtn_url: str = typer.Option(
        ..., help="The VTN, e.g. http://127.0.0.1:8080/OpenADR2/Simple/2.0b."
    ),
    ven_name: str = typer.Option(..., help="This VEN's name, as the VTN knows it."),
    url: str = typer.Option(..., help="The hvacflex service, e.g. http://127.0.0.1:8000."),
    building: list[str] = typer.Option(  # noqa: B008
        [], "--building", help="A building the VTN dispatches (repeat; default: all at start)."
    ),
    key_file: Path | None = typer.Option(  # noqa: B008
        None, help="File holding an operator key of the service (else $HVACFLEX_KEY)."
    ),
    cert: Path | None = typer.Option(  # noqa: B008
        None, help="TLS/signing: this VEN's certificate, PEM (with --key and --ca)."
    ),
    key: Path | None = typer.Option(  # noqa: B008
        None, help="TLS/signing: the private key of --cert, PEM (not the service key)."
    ),
    ca: Path | None = typer.Option(None, help="TLS: the CA of the VTN's certificate, PEM."),  # noqa: B008
    vtn_fingerprint: str | None = typer.Option(
        None, help="The VTN certificate's fingerprint: check the VTN's message signatures."
    ),
    clock_offset: str = typer.Option(
        "0s",
        help="Added to event times to get service times (30-min multiple), e.g. "
        "'-4656 days +01:30:00' to drive a 2014 scenario from a VTN on today's clock.",
    ),
    stop_after_s: float | None = typer.Option(
        None, help="Stop after this many seconds (else at SIGINT/SIGTERM)."
    ),
    db: str | None = typer.Option(
        None,
        "--db",
        help="The VEN's record (answers, activations, settlement): sqlite:///FILE or "
        "postgresql+psycopg://USER@HOST/DB; kept across restarts. Default: openadr-ven.db "
        "in the user data folder ($XDG_DATA_HOME/hvacflex, else ~/.local/share/hvacflex).",
        show_default=False,
    ),
) -> None:
    """OpenADR 2.0b VEN: VTN events become the service's prices, φ and IL activations; it
    reports metered power, planned power and the reserve offer, and settles the dispatches
    it accepted on metered power (docs/guide/service.md)."""
    import asyncio
    import logging
    from dataclasses import replace

    from hvacflex.errors import HvacflexError, require_extra

    try:
        require_extra("openadr", "hvacflex serve openadr-ven")
    except HvacflexError as exc:
        raise exit_on_error(exc) from None
    from hvacflex.service.openadr import VenConfig, parse_clock_offset, run_ven
    from hvacflex.service.replay import read_key

    try:
        config = VenConfig(
            vtn_url=vtn_url,
            ven_name=ven_name,
            service_url=url,
            operator_key=read_key(key_file),
            building_ids=tuple(building),
            clock_offset=parse_clock_offset(clock_offset),
            cert=cert,
            key=key,
            ca=ca,
            vtn_fingerprint=vtn_fingerprint,
            db_url=db,
        )
        if config.db_url is None:
            config = replace(config, db_url=config.record_url())
        logging.basicConfig(level=logging.INFO, format="%(asctime)s %(name)s %(message)s")
        typer.echo(
            f"hvacflex VEN {ven_name} → {vtn_url}; service {url}; record {config.db_url}",
            err=True,
        )
        asyncio.run(run_ven(config, stop_after_s=stop_after_s))
    except HvacflexError as exc:
        raise exit_on_error(exc) from None
