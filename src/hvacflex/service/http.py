"""The service's HTTP plumbing: the response envelope, the body limit and audit middleware,
the error handlers (every error in the envelope, naming the field) and the key checks as
FastAPI dependencies. The routes are in :mod:`.app`.
"""

import hashlib
import logging
from collections.abc import Awaitable, Callable, MutableMapping
from pathlib import Path
from typing import Annotated, Any

from fastapi import Depends, FastAPI, HTTPException, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse
from fastapi.security import APIKeyHeader
from sqlalchemy.exc import DataError, DBAPIError, IntegrityError, OperationalError, SQLAlchemyError
from sqlalchemy.orm import Session, sessionmaker
from starlette.concurrency import run_in_threadpool
from starlette.exceptions import HTTPException as StarletteHTTPException
from starlette.routing import Match

from hvacflex.errors import HvacflexError, InputError
from hvacflex.service.db import AuditEntry, bytes_as_text
from hvacflex.service.keys import KeyVerifier, Principal, RateLimitedError, VerifiedKeys
from hvacflex.service.runtime import NotFoundError
from hvacflex.service.schemas import ErrorEnvelope
from hvacflex.sim.step import ConflictError

MAX_BODY_BYTES = 1 << 20
"""Largest request body accepted (1 MiB); larger ones get 413."""
AUDIT_BODY_HEAD = 2000
"""Bytes of a mutating request's body kept in the audit table (as text: :func:`bytes_as_text`)."""
API_KEY_HEADER = "X-API-Key"
LOG = logging.getLogger("hvacflex.service")

Scope = MutableMapping[str, Any]
Message = MutableMapping[str, Any]
Receive = Callable[[], Awaitable[Message]]
Send = Callable[[Message], Awaitable[None]]
ASGIApp = Callable[[Scope, Receive, Send], Awaitable[None]]


def _enveloped(*answers: tuple[int, str]) -> dict[int | str, dict[str, Any]]:
    """OpenAPI responses: each (status, description) answered in the :class:`ErrorEnvelope`."""
    return {code: {"model": ErrorEnvelope, "description": text} for code, text in answers}


COMMON_ERRORS = _enveloped(
    (400, "The body is not JSON, or not UTF-8"),
    (404, "No such route, building or plan"),
    (405, "Method not allowed; the Allow header lists the route's methods"),
    (413, "Body too large"),
    (422, "Invalid input; the message names the field"),
    (503, "The database is not available; try again"),
)
"""Errors any route may answer (every one in the envelope)."""
ERRORS = {
    **COMMON_ERRORS,
    **_enveloped(
        (401, "No key, or an unknown or revoked key"),
        (403, "The key's role or building does not allow this"),
        (409, "Conflicts with what is stored"),
        (429, "Too many failed key attempts, or the key's budget on the route; see Retry-After"),
    ),
}
"""The errors of a route that needs a key."""
JSON_ERRORS: dict[int | str, dict[str, Any]] = {
    code: {
        "description": spec["description"],
        "content": {"application/json": {"schema": {"$ref": "#/components/schemas/ErrorEnvelope"}}},
    }
    for code, spec in COMMON_ERRORS.items()
}
"""The common errors of a route whose own answer is not JSON (``/v1/metrics``)."""
PACKAGE_DIR = Path(__file__).resolve().parents[1]
"""The installed package, named in no message (errors name shipped files by name only)."""


def envelope(status: int, message: str, payload: Any = None) -> JSONResponse:
    return JSONResponse({"status": status, "message": message, "payload": payload}, status)


class BodyLimitAndAudit:
    """ASGI middleware: refuse bodies over ``MAX_BODY_BYTES`` (413) and write an audit row
    for every mutating request before its response starts (a body refused by its
    ``Content-Length`` is not read: its row has no key, and the empty body's digest). The
    row is written in the threadpool, never on the event loop: a blocking database call
    there (a commit, a wait for a pooled connection) would stall every request at once."""

    def __init__(self, app: ASGIApp, sessions: sessionmaker[Session]) -> None:
        self.app = app
        self.sessions = sessions

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        headers = dict(scope.get("headers") or [])
        length = headers.get(b"content-length")
        mutating = scope["method"] in ("POST", "PUT", "PATCH", "DELETE")
        if length is not None and (not length.isdigit() or int(length) > MAX_BODY_BYTES):
            if mutating:  # refused unread: audited with the empty body's digest
                await run_in_threadpool(self._audit_or_log, scope, b"", 413)
            await envelope(413, f"body larger than {MAX_BODY_BYTES} bytes")(scope, receive, send)
            return
        body = bytearray()

        async def limited_receive() -> Message:
            message = await receive()
            if message["type"] == "http.request":
                body.extend(message.get("body", b""))
                if len(body) > MAX_BODY_BYTES:
                    raise HTTPException(413, f"body larger than {MAX_BODY_BYTES} bytes")
            return message

        async def audited_send(message: Message) -> None:
            if mutating and message["type"] == "http.response.start":
                await run_in_threadpool(
                    self._audit_or_log, scope, bytes(body), int(message["status"])
                )
            await send(message)

        await self.app(scope, limited_receive, audited_send)

    def _audit_or_log(self, scope: Scope, body: bytes, status: int) -> None:
        """:meth:`_audit`; a database that refuses the row is logged (an error line) and
        the response still goes out: raised here, after the request's own work is done,
        it would reach the server as an unanswered request and reset the connection."""
        try:
            self._audit(scope, body, status)
        except SQLAlchemyError as exc:
            LOG.error(
                "audit row not written: %s (%s %s, status %d)",
                type(getattr(exc, "orig", None) or exc).__name__,
                scope["method"],
                scope["path"],
                status,
            )

    def _audit(self, scope: Scope, body: bytes, status: int) -> None:
        principal = scope.get("state", {}).get("principal")
        with self.sessions() as session, session.begin():
            session.add(
                AuditEntry(
                    key_id=principal.key_id if principal else None,
                    role=principal.role if principal else None,
                    method=scope["method"],
                    path=str(scope["path"])[:512],
                    status_code=status,
                    body_sha256=hashlib.sha256(body).hexdigest(),
                    body_head=bytes_as_text(body[:AUDIT_BODY_HEAD]),
                )
            )


def allowed_methods(app: FastAPI, scope: Scope) -> list[str]:
    """The methods of every route whose path matches the request's (for ``Allow``)."""
    methods: set[str] = set()
    for route in app.router.routes:
        match, _ = route.matches({**scope, "method": "GET"})
        if match is not Match.NONE:
            methods |= set(getattr(route, "methods", None) or ())
    return sorted(methods)


def field_name(location: Any) -> str:
    """A pydantic error location as the field a client wrote: ``("body", "prices", 0)`` →
    ``prices[0]``; a query or path parameter keeps its kind (``query.period``)."""
    parts = list(location)
    if parts[:1] == ["body"] and len(parts) > 1:
        parts = parts[1:]
    name = ""
    for part in parts:
        name += f"[{part}]" if isinstance(part, int) else (f".{part}" if name else str(part))
    return name or "body"


def public_message(exc: HvacflexError) -> str:
    """The error's message without server paths: a file is named by its name alone."""
    text = str(exc)
    source = getattr(exc, "source", None)
    if source and ("/" in source or "\\" in source):
        text = text.replace(source, Path(source).name)
    return text.replace(str(PACKAGE_DIR), "hvacflex")


def database_error_status(exc: DBAPIError) -> tuple[int, str]:
    """The status and message a database driver's error is answered with (the driver's
    own text is not shown: it may quote stored data): a value the database refuses 422, a
    constraint 409, a database that does not answer 503, anything else 500."""
    kind = type(exc.orig).__name__ if exc.orig is not None else type(exc).__name__
    if isinstance(exc, DataError):
        return 422, f"the database refused a value of the request ({kind})"
    if isinstance(exc, IntegrityError):
        return 409, f"conflicts with what is stored ({kind})"
    if isinstance(exc, OperationalError):
        return 503, f"the database is not available; try again ({kind})"
    return 500, f"internal database error ({kind})"


def add_error_handlers(app: FastAPI) -> None:
    """Every error in the envelope; the project's input errors as 4xx naming the field."""

    @app.exception_handler(StarletteHTTPException)
    async def _http_error(request: Request, exc: StarletteHTTPException) -> JSONResponse:
        message = str(exc.detail)
        if exc.status_code == 400:
            message = "the body is not valid JSON in UTF-8"
        response = envelope(exc.status_code, message)
        if exc.headers:
            response.headers.update(exc.headers)
        if exc.status_code == 405:
            response.headers["Allow"] = ", ".join(allowed_methods(app, request.scope))
        return response

    @app.exception_handler(RequestValidationError)
    async def _validation_error(_request: Request, exc: RequestValidationError) -> JSONResponse:
        errors = [
            {"field": field_name(e.get("loc", ())), "message": str(e.get("msg"))}
            for e in exc.errors()
        ]
        if any(e.get("type") == "json_invalid" for e in exc.errors()):
            return envelope(400, "the body is not valid JSON", errors)
        first = errors[0] if errors else {"field": "body", "message": "invalid"}
        more = f" (and {len(errors) - 1} more)" if len(errors) > 1 else ""
        return envelope(422, f"field '{first['field']}': {first['message']}{more}", errors)

    @app.exception_handler(RateLimitedError)
    async def _rate_limited(_request: Request, exc: RateLimitedError) -> JSONResponse:
        response = envelope(429, str(exc))
        response.headers["Retry-After"] = str(max(1, round(exc.retry_after_s + 0.5)))
        return response

    @app.exception_handler(HvacflexError)
    async def _input_error(_request: Request, exc: HvacflexError) -> JSONResponse:
        status = (
            409
            if isinstance(exc, ConflictError)
            else 404
            if isinstance(exc, NotFoundError)
            else 422
        )
        field = exc.field if isinstance(exc, InputError) else None
        message = public_message(exc)
        return envelope(status, message, [{"field": field, "message": message}] if field else None)

    @app.exception_handler(DBAPIError)
    async def _database_error(_request: Request, exc: DBAPIError) -> JSONResponse:
        status, message = database_error_status(exc)
        return envelope(status, message)

    @app.exception_handler(Exception)
    async def _server_error(_request: Request, exc: Exception) -> JSONResponse:
        return envelope(500, f"internal error ({type(exc).__name__})")


API_KEY = APIKeyHeader(name=API_KEY_HEADER, auto_error=False)
"""The key header as a dependency (the key itself, or None; documented in OpenAPI)."""


class Auth:
    """The key checks, as FastAPI dependencies."""

    def __init__(
        self, sessions: sessionmaker[Session], read_sessions: sessionmaker[Session] | None = None
    ) -> None:
        self.sessions = sessions
        self.read_sessions = read_sessions or sessions
        """Where keys are looked up (a read: :func:`~.db.read_session_factory`)."""
        self.verifier = KeyVerifier()
        self.verified_keys = VerifiedKeys()
        """Keys verified here, for the plan read's check in memory (:meth:`cached`)."""

    def cached(self, request: Request, key: str | None) -> Principal | None:
        """The caller from the keys verified recently (:class:`~.keys.VerifiedKeys`, no
        database; on the event loop), or None: check it with :meth:`check`."""
        who = self.verified_keys.get(key) if key else None
        if who is not None:
            request.state.principal = who
        return who

    def poll_keys(self) -> None:
        """Read the stored keys' revocations for :meth:`cached` (off the event loop; a
        database error is logged: the keys stay unanswered from memory until a poll
        succeeds)."""
        try:
            with self.read_sessions() as session:
                self.verified_keys.poll(session)
        except Exception:
            LOG.exception("the keys' revocations could not be read")

    def principal(
        self, request: Request, key: Annotated[str | None, Depends(API_KEY)]
    ) -> Principal:
        """The caller (a dependency: run in the threadpool, one read of the key's row)."""
        with self.read_sessions() as session:
            return self.check(session, request, key)

    def check(self, session: Session, request: Request, key: str | None) -> Principal:
        """The caller of ``request`` with ``key``, its row read through ``session`` (a
        route that reads anyway checks its key on the same connection, in the same trip
        through the threadpool).

        Raises
        ------
        HTTPException : 401, no key or an unknown, revoked or wrong one.
        RateLimitedError : too many failed attempts (429).
        """
        if not key:
            raise HTTPException(401, f"missing {API_KEY_HEADER} header")
        client = request.client.host if request.client else "-"
        token = self.verified_keys.token()  # before the key's row is read
        who = self.verifier.verify(session, key, client)
        if who is None:
            raise HTTPException(401, "unknown or revoked key")
        self.verified_keys.put(key, who, token)
        request.state.principal = who
        return who


def check_building_reader(who: Principal, building_id: str) -> None:
    """Refuse (403) a building key reading another building (an operator reads all).

    Raises
    ------
    HTTPException : 403.
    """
    if who.role == "building" and who.building_id != building_id:
        raise HTTPException(403, "a building key reads only its own building")


def roles(auth: Auth) -> tuple[Any, Any, Any]:
    """The dependencies operator, building reader and building writer. They only compare
    (the key was checked by :meth:`Auth.principal`), so they run on the event loop: a sync
    dependency would cost every request one more trip through the threadpool."""

    async def operator(who: Annotated[Principal, Depends(auth.principal)]) -> Principal:
        if who.role != "operator":
            raise HTTPException(403, "this route needs an operator key")
        return who

    async def building_reader(
        building_id: str, who: Annotated[Principal, Depends(auth.principal)]
    ) -> Principal:
        check_building_reader(who, building_id)
        return who

    async def building_writer(
        building_id: str, who: Annotated[Principal, Depends(auth.principal)]
    ) -> Principal:
        if who.role != "building":
            raise HTTPException(403, "measurements are posted with the building's own key")
        if who.building_id != building_id:
            raise HTTPException(403, "a building key writes only its own building")
        return who

    return operator, building_reader, building_writer
