"""API keys: ``hvf_<key id>_<secret>``; only a salted scrypt hash of the secret is stored.

Roles: ``operator`` (grid or aggregator) and ``building`` (one building's BEMS). Verifying a
key costs one scrypt (~tens of ms); verified keys are remembered in memory by a SHA-256 of
the key, so later requests with the same key cost a dictionary lookup.
"""

from __future__ import annotations

import hashlib
import hmac
import secrets
import threading
from dataclasses import dataclass
from typing import Literal

from sqlalchemy.orm import Session

from hvacflex.errors import InputError
from hvacflex.service.db import ApiKey

Role = Literal["operator", "building"]
ROLES: tuple[Role, ...] = ("operator", "building")
KEY_PREFIX = "hvf"
_SCRYPT_N, _SCRYPT_R, _SCRYPT_P = 2**14, 8, 1


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


class KeyVerifier:
    """Checks keys against the stored hashes (constant-time), with a cache of verified keys."""

    def __init__(self) -> None:
        self._cache: dict[str, Principal] = {}
        self._lock = threading.Lock()

    def verify(self, session: Session, key: str) -> Principal | None:
        """The key's principal, or None for a malformed, unknown, revoked or wrong key."""
        digest = hashlib.sha256(key.encode()).hexdigest()
        with self._lock:
            cached = self._cache.get(digest)
        if cached is not None:
            return cached
        parts = key.split("_", 2)
        if len(parts) != 3 or parts[0] != KEY_PREFIX:
            return None
        _, key_id, secret = parts
        row = session.get(ApiKey, key_id)
        if row is None or row.revoked:
            _hash(secret, b"timing-equaliser")  # same work whether or not the id exists
            return None
        expected = bytes.fromhex(row.hash_hex)
        if not hmac.compare_digest(_hash(secret, bytes.fromhex(row.salt_hex)), expected):
            return None
        role: Role = "operator" if row.role == "operator" else "building"
        principal = Principal(key_id=row.key_id, role=role, building_id=row.building_id)
        with self._lock:
            self._cache[digest] = principal
        return principal
