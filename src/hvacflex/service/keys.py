"""API keys: ``hvf_<key id>_<secret>``; only a salted scrypt hash of the secret is stored.

Roles: ``operator`` (grid or aggregator) and ``building`` (one building's BEMS). Verifying a
key costs one scrypt (~tens of ms) the first time; afterwards a request costs one read of
the key's row (so a revocation holds from the next request). Refused keys are remembered
(negative cache). Failed attempts are rate-limited per client address and per key id
claimed (:class:`TokenBucket`): only failures count, so a flood of unknown keys costs little,
and a valid key used for the first time is refused only when both its address and its own
key id have failed too often — never for other keys' failures alone. Authenticated callers
have a budget per key on the costly routes (:class:`KeyBudgets`, :data:`DEFAULT_ROUTE_LIMITS`).

The plan read (the route buildings poll) checks its key in memory instead
(:class:`VerifiedKeys`): keys verified recently, forgotten whenever the stored keys'
revocations change — at once for a revocation made in this process, and within
:data:`KEY_CACHE_MAX_AGE_S` (typically :data:`KEY_POLL_S`) for one made by another process
(``hvacflex serve key revoke`` on the same database).
"""

from __future__ import annotations

import hashlib
import hmac
import math
import os
import re
import secrets
import threading
import time
from collections import OrderedDict
from collections.abc import Callable
from dataclasses import dataclass
from datetime import datetime
from pathlib import Path
from typing import Literal

from sqlalchemy import case, func, select
from sqlalchemy.orm import Session

from hvacflex.errors import HvacflexError, InputError
from hvacflex.service.db import PRIVATE_FILE_MODE, ApiKey

Role = Literal["operator", "building"]
ROLES: tuple[Role, ...] = ("operator", "building")
KEY_PREFIX = "hvf"
_SCRYPT_N, _SCRYPT_R, _SCRYPT_P = 2**14, 8, 1
KEY_ID_PATTERN = re.compile(r"[0-9a-f]{16}")
"""A key id: 16 lowercase hex digits (``secrets.token_hex(8)``)."""
NEGATIVE_CACHE_SIZE = 100_000
"""Refused keys remembered (by SHA-256) so that repeating one costs no scrypt."""
UNKNOWN_KEY_BURST = 10.0
"""Failed key attempts one client address (and, apart, one key id) may make at once."""
UNKNOWN_KEY_PER_S = 0.2
"""Such failures per address (per key id) per second after the burst [1/s]: each costs one
scrypt (≈ 0.05 s on an idle core, 0.5 s on the loaded shared machine), so one address can
hold at most a tenth of a core this way."""


KEY_POLL_S = 0.05
"""How often, while plan reads come, the stored keys' revocations are read for
:class:`VerifiedKeys` [s] (one small aggregate statement each time)."""
KEY_CACHE_MAX_AGE_S = 0.5
"""The longest a key revoked by another process may still read plans [s]: a key is
answered from memory only if the revocations were read within this long (else the
database is asked, as on every other route)."""


@dataclass(frozen=True)
class RouteLimit:
    """At most ``requests`` requests per key in ``window_s`` [s] on one route (a token
    bucket: a burst of ``requests``, refilled evenly over ``window_s``)."""

    requests: int
    window_s: float

    def __post_init__(self) -> None:
        if isinstance(self.requests, bool) or not isinstance(self.requests, int):
            raise InputError("must be a whole number of requests", value=self.requests)
        if self.requests < 1:
            raise InputError("must allow at least 1 request", value=self.requests)
        if not math.isfinite(self.window_s) or self.window_s <= 0:
            raise InputError(
                "the window must be a finite number of seconds > 0", value=self.window_s
            )

    def __str__(self) -> str:
        return f"{self.requests} per {self.window_s:g} s"


REGISTER_ROUTE = "POST /v1/buildings"
CLOCK_ROUTE = "POST /v1/clock"
DEFAULT_ROUTE_LIMITS: dict[str, RouteLimit] = {
    REGISTER_ROUTE: RouteLimit(10, 3600.0),  # builds a model (seconds of CPU)
    CLOCK_ROUTE: RouteLimit(1, 10.0),  # re-plans every building
}
"""The budget per key of the costly routes (``serve --register-limit``, ``--clock-limit``)."""


def parse_route_limit(text: str, option: str) -> RouteLimit:
    """``"N/SECONDS"`` (``"10/3600"``: 10 requests per hour) as a :class:`RouteLimit`.

    Raises
    ------
    InputError : not two positive numbers joined by ``/``, naming ``option``.
    """
    requests, _, window = text.partition("/")
    try:
        return RouteLimit(int(requests), float(window))
    except (ValueError, InputError):
        raise InputError(
            "not a limit N/SECONDS with N ≥ 1 requests and SECONDS > 0",
            field=option,
            value=text,
            hint=f"e.g. {option} 10/3600 (10 requests per key per hour)",
        ) from None


class RateLimitedError(HvacflexError):
    """Too many requests (HTTP 429, ``Retry-After``): failed key attempts, or a key's
    budget on a costly route."""

    def __init__(self, retry_after_s: float, message: str | None = None) -> None:
        self.retry_after_s = retry_after_s
        super().__init__(
            message or f"too many attempts with unknown keys; retry in {retry_after_s:.1f} s"
        )


@dataclass(frozen=True)
class Principal:
    """Who is calling: the key's id, its role and (for a building key) its building."""

    key_id: str
    role: Role
    building_id: str | None


def _hash(secret: str, salt: bytes) -> bytes:
    return hashlib.scrypt(
        secret.encode(), salt=salt, n=_SCRYPT_N, r=_SCRYPT_R, p=_SCRYPT_P, dklen=32
    )


def create_key(session: Session, role: str, building_id: str | None = None) -> str:
    """Store a new key (hashed) and return the full key, shown this once.

    Raises
    ------
    InputError : an unknown role, a building key without a building or an operator key with one.
    """
    if role not in ROLES:
        raise InputError("unknown role", field="role", value=role, hint=f"use one of {ROLES}")
    if role == "building" and not building_id:
        raise InputError("a building key needs its building", field="building")
    if role == "operator" and building_id:
        raise InputError("an operator key belongs to no building", field="building")
    key_id = secrets.token_hex(8)
    secret = secrets.token_urlsafe(32)
    salt = secrets.token_bytes(16)
    session.add(
        ApiKey(
            key_id=key_id,
            role=role,
            building_id=building_id,
            salt_hex=salt.hex(),
            hash_hex=_hash(secret, salt).hex(),
        )
    )
    return f"{KEY_PREFIX}_{key_id}_{secret}"


@dataclass(frozen=True)
class KeyInfo:
    """A stored key as ``serve key list`` prints it (never its secret or hash)."""

    key_id: str
    role: str
    building_id: str | None
    created_at: datetime
    revoked: bool


def list_keys(session: Session) -> list[KeyInfo]:
    """Every stored key, oldest first."""
    rows = session.scalars(select(ApiKey).order_by(ApiKey.created_at, ApiKey.key_id))
    return [KeyInfo(r.key_id, r.role, r.building_id, r.created_at, bool(r.revoked)) for r in rows]


def revoke_key(session: Session, key_id: str) -> bool:
    """Mark a key revoked (the running service refuses it from its next request on).

    Returns whether it was revoked before.

    Raises
    ------
    InputError : no key has this id.
    """
    if not KEY_ID_PATTERN.fullmatch(key_id):
        raise InputError(
            "not a key id",
            field="KEY_ID",
            value=key_id,
            hint="a key id is the 16 hex digits after hvf_ (see `serve key list`)",
        )
    row = session.get(ApiKey, key_id)
    if row is None:
        raise InputError("no such key", field="KEY_ID", value=key_id, hint="see `serve key list`")
    was = bool(row.revoked)
    row.revoked = True
    global _REVOCATIONS_HERE
    _REVOCATIONS_HERE += 1  # every VerifiedKeys of this process forgets its keys
    return was


_REVOCATIONS_HERE = 0
"""Keys revoked by this process (:func:`revoke_key`), for :class:`VerifiedKeys`."""


def revocations_fingerprint(session: Session) -> tuple[int, int]:
    """(stored keys, revoked keys): changes whenever a key is revoked (keys are never
    deleted or restored), whoever revoked it."""
    total, revoked = session.execute(
        select(func.count(), func.coalesce(func.sum(case((ApiKey.revoked, 1), else_=0)), 0))
    ).one()
    return int(total), int(revoked)


class VerifiedKeys:
    """Principals of keys verified recently, by the key's SHA-256, answered without the
    database while the stored keys' revocations are known to be unchanged.

    * :meth:`poll` reads :func:`revocations_fingerprint` (the caller runs it off the event
      loop, every ``poll_s`` while reads come: :meth:`poll_due`); a change, or the first
      poll, forgets every key.
    * :meth:`get` answers a key only if the last poll started less than ``max_age_s`` ago
      and no key was revoked in this process since: a key revoked (by anyone) before that
      poll started is not answered, so a revocation holds within ``max_age_s``.
    * :meth:`put` keeps a key just verified against its stored row, with the
      :meth:`token` taken before that row was read: a key forgotten meanwhile is not put.
    """

    def __init__(
        self,
        poll_s: float = KEY_POLL_S,
        max_age_s: float = KEY_CACHE_MAX_AGE_S,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.poll_s, self.max_age_s, self.clock = poll_s, max_age_s, clock
        self._principals: dict[str, Principal] = {}
        self._generation = 0
        self._fingerprint: tuple[int, int] | None = None
        self._polled_from: float | None = None
        """When the last finished poll started (None: none finished)."""
        self._poll_started: float | None = None
        self._polling = False
        self._revocations_here = _REVOCATIONS_HERE
        self._lock = threading.Lock()

    def get(self, key: str) -> Principal | None:
        """The key's principal if it is known here and fresh, else None (ask the
        database)."""
        polled_from = self._polled_from
        if polled_from is None or self.clock() - polled_from > self.max_age_s:
            return None
        if self._revocations_here != _REVOCATIONS_HERE:
            with self._lock:
                self._check_here()
            return None
        return self._principals.get(_digest(key))

    def token(self) -> int:
        """Take before reading a key's row (for :meth:`put`)."""
        with self._lock:
            self._check_here()
            return self._generation

    def put(self, key: str, principal: Principal, token: int) -> None:
        """Keep ``key``, verified on a row read after :meth:`token` returned ``token``."""
        with self._lock:
            self._check_here()
            if token == self._generation:
                self._principals[_digest(key)] = principal

    def poll_due(self) -> bool:
        """Whether a poll should start now (none running, the last started ``poll_s``
        ago); if so, it counts as started."""
        now = self.clock()
        with self._lock:
            if self._polling or (
                self._poll_started is not None and now - self._poll_started < self.poll_s
            ):
                return False
            self._polling, self._poll_started = True, now
            return True

    def poll(self, session: Session) -> None:
        """Read the revocations (after :meth:`poll_due` said so); forget every key if they
        changed or were never read."""
        started = self._poll_started if self._poll_started is not None else self.clock()
        try:
            fingerprint = revocations_fingerprint(session)
        except BaseException:
            with self._lock:
                self._polling = False
            raise
        with self._lock:
            self._polling = False
            if fingerprint != self._fingerprint:
                self._forget_locked()
                self._fingerprint = fingerprint
            self._polled_from = started

    def _check_here(self) -> None:
        """Forget every key if this process revoked one since (the caller holds the lock)."""
        if self._revocations_here != _REVOCATIONS_HERE:
            self._forget_locked()

    def _forget_locked(self) -> None:
        self._principals = {}
        self._generation += 1
        self._revocations_here = _REVOCATIONS_HERE


class TokenBucket:
    """Per-client token buckets: ``capacity`` attempts at once, ``refill_per_s`` after that.

    Parameters
    ----------
    capacity : tokens a client starts with (a burst).
    refill_per_s : tokens added per second [1/s].
    max_clients : clients remembered (the least recently seen is forgotten first).
    """

    def __init__(self, capacity: float, refill_per_s: float, max_clients: int = 10_000) -> None:
        self.capacity = capacity
        self.refill_per_s = refill_per_s
        self.max_clients = max_clients
        self._buckets: OrderedDict[str, tuple[float, float]] = OrderedDict()
        self._lock = threading.Lock()

    def take(self, client: str, now_s: float | None = None) -> float:
        """Take one token for ``client``: 0.0 when granted, else the seconds until one is."""
        return self._update(client, now_s, take=True)

    def wait_s(self, client: str, now_s: float | None = None) -> float:
        """Seconds until ``client`` has a token (0.0: it has one now); takes none."""
        return self._update(client, now_s, take=False)

    def spend(self, client: str, now_s: float | None = None) -> None:
        """Take one token for ``client`` if it has one (a failure counted after the fact)."""
        self._update(client, now_s, take=True)

    def _update(self, client: str, now_s: float | None, *, take: bool) -> float:
        now = time.monotonic() if now_s is None else now_s
        with self._lock:
            tokens, then = self._buckets.pop(client, (self.capacity, now))
            tokens = min(self.capacity, tokens + (now - then) * self.refill_per_s)
            wait_s = 0.0 if tokens >= 1.0 else (1.0 - tokens) / self.refill_per_s
            self._buckets[client] = (tokens - 1.0 if take and wait_s == 0.0 else tokens, now)
            while len(self._buckets) > self.max_clients:
                self._buckets.popitem(last=False)
        return wait_s


class KeyBudgets:
    """Each key's budget on the costly routes (:class:`RouteLimit` per route).

    Parameters
    ----------
    limits : route (``"POST /v1/clock"``) → its limit; routes not named are not limited
        (default :data:`DEFAULT_ROUTE_LIMITS`).
    """

    def __init__(self, limits: dict[str, RouteLimit] | None = None) -> None:
        self.limits = dict(DEFAULT_ROUTE_LIMITS if limits is None else limits)
        self._buckets = {
            route: TokenBucket(float(limit.requests), limit.requests / limit.window_s)
            for route, limit in self.limits.items()
        }

    def spend(self, route: str, key_id: str, now_s: float | None = None) -> None:
        """Count one request of ``key_id`` on ``route``.

        Raises
        ------
        RateLimitedError : the key has used its budget on the route (HTTP 429 with
            ``Retry-After``).
        """
        bucket = self._buckets.get(route)
        if bucket is None:
            return
        wait_s = bucket.take(key_id, now_s)
        if wait_s > 0.0:
            raise RateLimitedError(
                wait_s,
                f"this key's budget on {route} is {self.limits[route]}; retry in {wait_s:.1f} s",
            )


class KeyVerifier:
    """Checks keys against the stored hashes (constant-time).

    A key whose secret verified once is remembered by its SHA-256, so later requests skip
    the scrypt, but the key's row is read on every request: a revocation takes effect on
    the next one. A key that failed is remembered too (a bounded negative cache), so the
    same unknown key costs a dictionary lookup.
    """

    def __init__(
        self,
        attempts: TokenBucket | None = None,
        negative_cache_size: int = NEGATIVE_CACHE_SIZE,
        key_attempts: TokenBucket | None = None,
    ) -> None:
        self.attempts = attempts or TokenBucket(UNKNOWN_KEY_BURST, UNKNOWN_KEY_PER_S)
        self.key_attempts = key_attempts or TokenBucket(UNKNOWN_KEY_BURST, UNKNOWN_KEY_PER_S)
        self._verified: dict[str, str] = {}
        self._refused: OrderedDict[str, None] = OrderedDict()
        self._negative_cache_size = negative_cache_size
        self._lock = threading.Lock()

    def verify(self, session: Session, key: str, client: str = "-") -> Principal | None:
        """The key's principal, or None for a malformed, unknown, revoked or wrong key.

        A key not verified before costs one scrypt. Only failures are counted, per client
        address (``client``) and per key id claimed: an attempt is refused unverified only
        when the address has failed too often and the key id it claims is unknown, revoked
        or has failed too often itself — so a valid key is never refused for the failures
        of other keys.

        Raises
        ------
        RateLimitedError : as above; it may try again after ``retry_after_s``.
        """
        parts = _split(key)
        if parts is None:
            return None
        key_id, secret = parts
        digest = _digest(key)
        with self._lock:
            if digest in self._refused:
                return None
            verified = self._verified.get(digest) == key_id
        row = session.get(ApiKey, key_id)
        if row is None or row.revoked:
            if not verified:
                self._check_attempt(key_id, client, active=False)
                _hash(secret, b"timing-equaliser")  # same work whether or not the id exists
                self._failed(key_id, client)
            self._refuse(digest)
            return None
        if not verified:
            self._check_attempt(key_id, client, active=True)
            expected = bytes.fromhex(row.hash_hex)
            if not hmac.compare_digest(_hash(secret, bytes.fromhex(row.salt_hex)), expected):
                self._failed(key_id, client)
                self._refuse(digest)
                return None
            with self._lock:
                self._verified[digest] = key_id
        role: Role = "operator" if row.role == "operator" else "building"
        return Principal(key_id=row.key_id, role=role, building_id=row.building_id)

    def _check_attempt(self, key_id: str, client: str, *, active: bool) -> None:
        """Refuse (429) a first attempt of ``client`` at ``key_id`` when the address has no
        failure left and the key id is not an active key with failures left."""
        client_wait_s = self.attempts.wait_s(client)
        if client_wait_s == 0.0:
            return
        key_wait_s = self.key_attempts.wait_s(key_id) if active else math.inf
        if key_wait_s > 0.0:
            raise RateLimitedError(min(client_wait_s, key_wait_s))

    def _failed(self, key_id: str, client: str) -> None:
        self.attempts.spend(client)
        self.key_attempts.spend(key_id)

    def _refuse(self, digest: str) -> None:
        with self._lock:
            self._verified.pop(digest, None)
            self._refused[digest] = None
            while len(self._refused) > self._negative_cache_size:
                self._refused.popitem(last=False)


def _digest(key: str) -> str:
    return hashlib.sha256(key.encode()).hexdigest()


def _split(key: str) -> tuple[str, str] | None:
    """``(key id, secret)`` of a well-formed key, else None."""
    parts = key.split("_", 2)
    if len(parts) != 3 or parts[0] != KEY_PREFIX or not KEY_ID_PATTERN.fullmatch(parts[1]):
        return None
    return parts[1], parts[2]


def write_key_file(path: Path, key: str) -> None:
    """Write ``key`` to a new file of mode 0600 (an existing file is never overwritten).

    Raises
    ------
    InputError : the file exists, or its folder is missing or not writable.
    """
    try:
        descriptor = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, PRIVATE_FILE_MODE)
    except FileExistsError:
        raise InputError(
            "the key file exists already",
            field="--key-file",
            value=str(path),
            hint="choose a new file (a key file is never overwritten)",
        ) from None
    except OSError as exc:
        raise InputError(
            f"cannot create the key file ({exc.strerror or exc})",
            field="--key-file",
            value=str(path),
        ) from None
    with os.fdopen(descriptor, "w", encoding="utf-8") as handle:
        handle.write(key + "\n")
