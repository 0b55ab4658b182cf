"""API keys: ``hvf_<key id>_<secret>``; only a salted scrypt hash of the secret is stored.

Roles: ``operator`` (grid or aggregator) and ``building`` (one building's BEMS). Verifying a
key costs one scrypt (~tens of ms) the first time; afterwards a request costs one read of
the key's row (so a revocation holds from the next request). Refused keys are remembered
(negative cache), and the app rate-limits unknown-key attempts per client
(:class:`TokenBucket`), so a flood of unknown keys costs little and cannot starve valid ones.
"""

from __future__ import annotations

import hashlib
import hmac
import os
import re
import secrets
import threading
import time
from collections import OrderedDict
from dataclasses import dataclass
from datetime import datetime
from pathlib import Path
from typing import Literal

from sqlalchemy import select
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
"""Attempts at keys not verified before that one client may make at once."""
UNKNOWN_KEY_PER_S = 0.2
"""Such attempts per client per second after the burst [1/s]: each costs one scrypt
(≈ 0.05 s on an idle core, 0.5 s on the loaded shared machine), so one client can hold at
most a tenth of a core this way."""


class RateLimitedError(HvacflexError):
    """A client made too many attempts at unknown keys (HTTP 429)."""

    def __init__(self, retry_after_s: float) -> None:
        self.retry_after_s = retry_after_s
        super().__init__(f"too many attempts with unknown keys; retry in {retry_after_s:.1f} s")


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
    return was


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
        now = time.monotonic() if now_s is None else now_s
        with self._lock:
            tokens, then = self._buckets.pop(client, (self.capacity, now))
            tokens = min(self.capacity, tokens + (now - then) * self.refill_per_s)
            wait_s = 0.0 if tokens >= 1.0 else (1.0 - tokens) / self.refill_per_s
            self._buckets[client] = (tokens - 1.0 if wait_s == 0.0 else tokens, now)
            while len(self._buckets) > self.max_clients:
                self._buckets.popitem(last=False)
        return wait_s


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
    ) -> None:
        self.attempts = attempts or TokenBucket(UNKNOWN_KEY_BURST, UNKNOWN_KEY_PER_S)
        self._verified: dict[str, str] = {}
        self._refused: OrderedDict[str, None] = OrderedDict()
        self._negative_cache_size = negative_cache_size
        self._lock = threading.Lock()

    def verify(self, session: Session, key: str, client: str = "-") -> Principal | None:
        """The key's principal, or None for a malformed, unknown, revoked or wrong key.

        Raises
        ------
        RateLimitedError : ``client`` has used up its attempts at keys not verified before
            (one scrypt each); it may try again after ``retry_after_s``.
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
        if not verified:
            wait_s = self.attempts.take(client)
            if wait_s > 0.0:
                raise RateLimitedError(wait_s)
        row = session.get(ApiKey, key_id)
        if row is None or row.revoked:
            if not verified:
                _hash(secret, b"timing-equaliser")  # same work whether or not the id exists
            self._refuse(digest)
            return None
        if not verified:
            expected = bytes.fromhex(row.hash_hex)
            if not hmac.compare_digest(_hash(secret, bytes.fromhex(row.salt_hex)), expected):
                self._refuse(digest)
                return None
            with self._lock:
                self._verified[digest] = key_id
        role: Role = "operator" if row.role == "operator" else "building"
        return Principal(key_id=row.key_id, role=role, building_id=row.building_id)

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
