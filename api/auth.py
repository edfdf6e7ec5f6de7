"""API keys and roles.

Roles are ordered: observer (read) < operator (runs, compensation) < admin (keys, e-stop
reset).  Any valid key may trigger the e-stop.  A key is 32 random bytes (url-safe text); it
is stored only as its SHA-256 in ``api_keys.json`` (mode 0600) in the data directory.  A
salted slow hash (pbkdf2) protects low-entropy passwords; these keys have 256 bits of
entropy, and a fast hash keeps authentication out of the request latency budget.

On first start an admin key is generated and written to ``admin.key`` (mode 0600) in the
data directory; the server prints that file's path, never the key.  The environment variable
``BENCH_API_KEY``, when set, is accepted as an admin key (scripts, CI).

The key file is only trusted when this server's user owns it and neither group nor others
may write it (``bench.private.trusted``): at start-up an untrusted file is refused (one
line), and a change to it while the server runs is ignored (the keys known stay).  At most
``MAX_KEYS`` keys exist at once.
"""
from __future__ import annotations

import hashlib
import hmac
import json
import os
import secrets
import threading
import time
import uuid
from dataclasses import dataclass
from pathlib import Path

from bench.errors import BenchError, InputError
from bench.private import private_dir, trusted

ROLES = ("observer", "operator", "admin")
KEYS_FILE = "api_keys.json"
ADMIN_KEY_FILE = "admin.key"
ENV_KEY = "BENCH_API_KEY"
MAX_KEYS = 256          # a bench has a handful of people and scripts; a fuzzer made 4,744


class TooManyKeys(BenchError):
    """The key cap is reached: revoke unused keys first (409)."""


@dataclass(frozen=True)
class Principal:
    key_id: str
    name: str
    role: str

    def allows(self, role: str) -> bool:
        return ROLES.index(self.role) >= ROLES.index(role)


def _digest(key: str) -> str:
    return hashlib.sha256(key.encode()).hexdigest()


def _write_private(path: Path, text: str) -> None:
    """Create/replace ``path`` with mode 0600 from the start (no window where it is readable)."""
    tmp = path.with_name(path.name + ".tmp")
    fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
    try:
        os.write(fd, text.encode())
    finally:
        os.close(fd)
    os.chmod(tmp, 0o600)
    os.replace(tmp, path)


class KeyStore:
    def __init__(self, data_dir: str | Path, env_key: str | None = None):
        self.dir = private_dir(data_dir)
        self.path = self.dir / KEYS_FILE
        self._lock = threading.Lock()
        self._keys: dict[str, dict] = {}      # digest -> {id, name, role, created}
        self._env_digest = _digest(env_key) if env_key else None
        self._mtime: float | None = None
        self._load()

    def _load(self) -> None:
        """(Re)read the key file when it changed: ``bench api-key`` may add keys while the
        server runs."""
        try:
            mtime = self.path.stat().st_mtime_ns
        except FileNotFoundError:
            return
        if mtime == self._mtime:
            return
        why = trusted(self.path)
        if why is not None:
            raise InputError(f"key file not trusted: {why}")
        try:
            entries = json.loads(self.path.read_text())
            self._keys = {e["sha256"]: e for e in entries}
        except (ValueError, KeyError, TypeError) as e:
            raise InputError(f"{self.path}: unreadable key file ({e.__class__.__name__}); "
                             f"move it away to start with a new admin key") from None
        self._mtime = mtime

    @property
    def admin_key_path(self) -> Path:
        return self.dir / ADMIN_KEY_FILE

    def ensure_admin(self) -> Path | None:
        """Generate the first admin key if there is none; returns the file holding it (or
        None when admin keys exist already and its file was removed)."""
        with self._lock:
            if any(e["role"] == "admin" for e in self._keys.values()):
                return self.admin_key_path if self.admin_key_path.exists() else None
        key, _ = self.create("admin", "first admin key")
        _write_private(self.admin_key_path, key + "\n")
        return self.admin_key_path

    def create(self, role: str, name: str = "") -> tuple[str, dict]:
        if role not in ROLES:
            raise InputError(f"role must be one of {', '.join(ROLES)}, got {role!r}")
        key = secrets.token_urlsafe(32)
        entry = {"id": uuid.uuid4().hex[:12], "name": name or role, "role": role,
                 "created": time.time(), "sha256": _digest(key)}
        with self._lock:
            self._load()
            if len(self._keys) >= MAX_KEYS:
                raise TooManyKeys(f"{len(self._keys)} API keys exist (limit {MAX_KEYS}); revoke unused ones first")
            self._keys[entry["sha256"]] = entry
            self._save()
        return key, self.public(entry)

    def revoke(self, key_id: str) -> bool:
        with self._lock:
            self._load()
            for digest, e in list(self._keys.items()):
                if e["id"] == key_id:
                    del self._keys[digest]
                    self._save()
                    return True
        return False

    def list(self) -> list[dict]:
        with self._lock:
            return [self.public(e) for e in self._keys.values()]

    @staticmethod
    def public(e: dict) -> dict:
        return {k: e[k] for k in ("id", "name", "role", "created")}

    def authenticate(self, key: str) -> Principal | None:
        digest = _digest(key)
        if self._env_digest is not None and hmac.compare_digest(digest, self._env_digest):
            return Principal("env", ENV_KEY, "admin")
        with self._lock:
            try:
                self._load()
            except InputError:      # a half-edited or untrusted file: keep the keys we know
                pass
            e = self._keys.get(digest)
        return None if e is None else Principal(e["id"], e["name"], e["role"])

    def _save(self) -> None:
        _write_private(self.path, json.dumps(list(self._keys.values()), indent=1))
        self._mtime = self.path.stat().st_mtime_ns
