"""Run records: an embedded SQLite database (WAL) plus one trace directory per run.

A run is a stream of documents (start, events, stop, Bluesky style).  ``Store.emit`` is the
sink a procedure's emitter feeds; the API streams the same documents over SSE by polling
``events(run_id, after_seq)``.  Thread safety: one connection per thread (WAL lets readers
run beside the writer), and ``busy_timeout`` for concurrent writers.

States: queued | running | succeeded | failed | cancelled | interrupted.  A run found
``running`` by a new process whose owner PID is dead was killed mid-run: ``recover`` marks
it ``interrupted``; its trace stays readable (see ``bench.traces``).
"""
from __future__ import annotations

import json
import os
import socket
import sqlite3
import subprocess
import threading
import time
import uuid
from pathlib import Path

from bench.errors import InputError
from bench.private import private_dir, private_file

STATES = ("queued", "running", "succeeded", "failed", "cancelled", "interrupted")
FINAL = ("succeeded", "failed", "cancelled", "interrupted")

_SCHEMA = """
CREATE TABLE IF NOT EXISTS runs (
  id TEXT PRIMARY KEY, kind TEXT NOT NULL, state TEXT NOT NULL, parent_id TEXT, joint_id TEXT,
  created REAL NOT NULL, started REAL, ended REAL, owner_pid INTEGER, owner_host TEXT,
  config TEXT, software TEXT, seed INTEGER, result TEXT, error TEXT);
CREATE INDEX IF NOT EXISTS runs_parent ON runs(parent_id);
CREATE TABLE IF NOT EXISTS events (
  run_id TEXT NOT NULL, seq INTEGER NOT NULL, time REAL NOT NULL, doc TEXT NOT NULL, name TEXT,
  data TEXT, PRIMARY KEY (run_id, seq));
CREATE TABLE IF NOT EXISTS models (
  id TEXT PRIMARY KEY, joint_id TEXT NOT NULL, run_id TEXT, created REAL NOT NULL,
  params TEXT NOT NULL, report TEXT);
CREATE TABLE IF NOT EXISTS compensation (
  joint_id TEXT PRIMARY KEY, enabled INTEGER NOT NULL, model_id TEXT, updated REAL NOT NULL);
CREATE TABLE IF NOT EXISTS estop (
  id INTEGER PRIMARY KEY CHECK (id = 1), reason TEXT NOT NULL, triggered_at REAL, drives TEXT);
"""


def software_version() -> str:
    import bench
    v = bench.__version__
    try:
        out = subprocess.run(["git", "describe", "--always", "--dirty", "--tags"], capture_output=True,
                             text=True, timeout=5, cwd=Path(__file__).resolve().parent.parent)
        if out.returncode == 0 and out.stdout.strip():
            v += "+" + out.stdout.strip()
    except (OSError, subprocess.SubprocessError):
        pass
    return v


def pid_alive(pid: int | None) -> bool:
    if not pid:
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    try:  # a zombie (killed child not yet reaped) is dead for our purpose
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return True


class Store:
    def __init__(self, data_dir: str | Path):
        self.dir = private_dir(data_dir)       # 0700 and 0600, whatever the umask
        self.path = self.dir / "runs.sqlite"
        for suffix in ("", "-wal", "-shm"):    # SQLite gives its WAL and SHM the db's mode
            if suffix == "" or Path(f"{self.path}{suffix}").exists():
                private_file(f"{self.path}{suffix}")
        self._local = threading.local()
        self._version: str | None = None
        self._conn().executescript(_SCHEMA)

    # --- connections -----------------------------------------------------------------------
    def _conn(self) -> sqlite3.Connection:
        c = getattr(self._local, "conn", None)
        if c is None:
            c = sqlite3.connect(self.path, timeout=30, isolation_level=None)
            c.row_factory = sqlite3.Row
            c.execute("PRAGMA journal_mode=WAL")
            c.execute("PRAGMA synchronous=NORMAL")
            c.execute("PRAGMA busy_timeout=30000")
            self._local.conn = c
        return c

    class _Tx:
        def __init__(self, c):
            self.c = c

        def __enter__(self):
            self.c.execute("BEGIN IMMEDIATE")
            return self.c

        def __exit__(self, et, e, tb):
            self.c.execute("COMMIT" if et is None else "ROLLBACK")

    def _tx(self):
        return Store._Tx(self._conn())

    def run_dir(self, run_id: str) -> Path:
        return self.dir / "runs" / run_id

    # --- runs ------------------------------------------------------------------------------
    def create_run(self, kind: str, config: dict | None = None, seed: int | None = None,
                   parent_id: str | None = None, joint_id: str | None = None,
                   state: str = "running") -> str:
        if self._version is None:
            self._version = software_version()
        run_id = time.strftime("%Y%m%dT%H%M%S") + "-" + uuid.uuid4().hex[:8]
        now = time.time()
        with self._tx() as c:
            c.execute("INSERT INTO runs (id, kind, state, parent_id, joint_id, created, started, owner_pid,"
                      " owner_host, config, software, seed) VALUES (?,?,?,?,?,?,?,?,?,?,?,?)",
                      (run_id, kind, state, parent_id, joint_id, now, now if state == "running" else None,
                       os.getpid(), socket.gethostname(), json.dumps(config or {}), self._version, seed))
        self.run_dir(run_id).mkdir(parents=True, exist_ok=True)
        return run_id

    def claim(self, run_id: str) -> None:
        """Take over a run (a queued one starting, or a resume): this process owns it and it is
        running; ``started`` keeps the first start."""
        with self._tx() as c:
            c.execute("UPDATE runs SET state='running', owner_pid=?, owner_host=?, ended=NULL, error=NULL,"
                      " started=COALESCE(started, ?) WHERE id=?",
                      (os.getpid(), socket.gethostname(), time.time(), run_id))

    def finish_run(self, run_id: str, state: str, result: dict | None = None, error: str | None = None):
        if state not in FINAL:
            raise ValueError(f"not a final state: {state}")
        with self._tx() as c:
            c.execute("UPDATE runs SET state=?, ended=?, result=COALESCE(?, result), error=? WHERE id=?",
                      (state, time.time(), None if result is None else json.dumps(result), error, run_id))

    def set_result(self, run_id: str, result: dict) -> None:
        with self._tx() as c:
            c.execute("UPDATE runs SET result=? WHERE id=?", (json.dumps(result), run_id))

    def get_run(self, run_id: str) -> dict:
        row = self._conn().execute("SELECT * FROM runs WHERE id=?", (run_id,)).fetchone()
        if row is None:
            raise InputError(f"no run {run_id!r}")
        return _run_dict(row)

    def list_runs(self, kind: str | None = None, state: str | None = None, parent_id: str | None = None,
                  joint_id: str | None = None, limit: int = 100) -> list[dict]:
        where, args = [], []
        for col, val in (("kind", kind), ("state", state), ("parent_id", parent_id), ("joint_id", joint_id)):
            if val is not None:
                where.append(f"{col}=?")
                args.append(val)
        sql = "SELECT * FROM runs" + (" WHERE " + " AND ".join(where) if where else "")
        sql += " ORDER BY created DESC, rowid DESC LIMIT ?"
        return [_run_dict(r) for r in self._conn().execute(sql, (*args, limit))]

    def set_progress(self, run_id: str, progress: float) -> None:
        """The live progress of a running run, kept so that a crash does not reset it."""
        with self._tx() as c:
            c.execute("UPDATE runs SET result=json_set(COALESCE(result, '{}'), '$.progress', ?)"
                      " WHERE id=? AND state='running'", (float(progress), run_id))

    def recover(self) -> list[str]:
        """Mark runs left 'running' by a dead process on this host as 'interrupted': ended
        when they were last heard of (their newest document), their progress as recorded."""
        host = socket.gethostname()
        rows = self._conn().execute("SELECT id, owner_pid, owner_host, started, created FROM runs"
                                    " WHERE state='running'").fetchall()
        dead = [r for r in rows if r["owner_host"] == host and not pid_alive(r["owner_pid"])]
        for r in dead:
            last = self._conn().execute("SELECT MAX(time) FROM events WHERE run_id=?", (r["id"],)).fetchone()[0]
            ended = max(x for x in (last, r["started"], r["created"]) if x is not None)
            with self._tx() as c:
                c.execute("UPDATE runs SET state='interrupted', ended=?, error=? WHERE id=? AND state='running'",
                          (ended, "owner process died mid-run", r["id"]))
        return [r["id"] for r in dead]

    # --- the e-stop latch (api.safety): state, not memory --------------------------------------
    def set_latch(self, reason: str, triggered_at: float | None, drives: list | None = None) -> None:
        with self._tx() as c:
            c.execute("INSERT OR REPLACE INTO estop (id, reason, triggered_at, drives) VALUES (1,?,?,?)",
                      (reason, triggered_at, json.dumps(drives or [], default=_jsonable)))

    def clear_latch(self) -> None:
        with self._tx() as c:
            c.execute("DELETE FROM estop")

    def get_latch(self) -> dict | None:
        r = self._conn().execute("SELECT reason, triggered_at, drives FROM estop WHERE id=1").fetchone()
        if r is None:
            return None
        return {"reason": r["reason"], "triggered_at": r["triggered_at"], "drives": json.loads(r["drives"] or "[]")}

    # --- documents -------------------------------------------------------------------------
    def emit(self, doc: dict) -> None:
        """Persist one document {run_id, seq, time, doc, name, data}."""
        with self._tx() as c:
            c.execute("INSERT OR REPLACE INTO events (run_id, seq, time, doc, name, data) VALUES (?,?,?,?,?,?)",
                      (doc["run_id"], doc["seq"], doc["time"], doc["doc"], doc.get("name"),
                       json.dumps(doc.get("data", {}), default=_jsonable)))

    def events(self, run_id: str, after_seq: int = -1) -> list[dict]:
        rows = self._conn().execute("SELECT * FROM events WHERE run_id=? AND seq>? ORDER BY seq",
                                    (run_id, after_seq)).fetchall()
        return [{"run_id": r["run_id"], "seq": r["seq"], "time": r["time"], "doc": r["doc"],
                 "name": r["name"], "data": json.loads(r["data"] or "{}")} for r in rows]

    def last_seq(self, run_id: str) -> int:
        r = self._conn().execute("SELECT MAX(seq) FROM events WHERE run_id=?", (run_id,)).fetchone()
        return -1 if r[0] is None else int(r[0])

    # --- models and the compensation switch --------------------------------------------------
    def add_model(self, joint_id: str, params: dict, report: dict | None, run_id: str | None) -> str:
        model_id = f"{joint_id}-" + time.strftime("%Y%m%dT%H%M%S") + "-" + uuid.uuid4().hex[:6]
        with self._tx() as c:
            c.execute("INSERT INTO models (id, joint_id, run_id, created, params, report) VALUES (?,?,?,?,?,?)",
                      (model_id, joint_id, run_id, time.time(), json.dumps(params),
                       json.dumps(report, default=_jsonable)))
        return model_id

    def get_model(self, model_id: str) -> dict:
        r = self._conn().execute("SELECT * FROM models WHERE id=?", (model_id,)).fetchone()
        if r is None:
            raise InputError(f"no model {model_id!r}")
        return _model_dict(r)

    def list_models(self, joint_id: str | None = None) -> list[dict]:
        sql, args = "SELECT * FROM models", ()
        if joint_id is not None:
            sql, args = sql + " WHERE joint_id=?", (joint_id,)
        return [_model_dict(r) for r in self._conn().execute(sql + " ORDER BY created DESC, rowid DESC", args)]

    def get_compensation(self, joint_id: str) -> dict:
        r = self._conn().execute("SELECT * FROM compensation WHERE joint_id=?", (joint_id,)).fetchone()
        if r is None:
            return {"joint_id": joint_id, "enabled": False, "model_id": None, "updated": None}
        return {"joint_id": joint_id, "enabled": bool(r["enabled"]), "model_id": r["model_id"],
                "updated": r["updated"]}

    def set_compensation(self, joint_id: str, enabled: bool, model_id: str | None = None) -> dict:
        """Switch compensation for a joint; ``model_id`` None keeps the current model, or
        takes the joint's newest model if it has none yet."""
        if model_id is not None:
            m = self.get_model(model_id)
            if m["joint_id"] != joint_id:
                raise InputError(f"model {model_id!r} belongs to joint {m['joint_id']!r}, not {joint_id!r}")
        else:
            model_id = self.get_compensation(joint_id)["model_id"]
            if model_id is None:
                models = self.list_models(joint_id)
                model_id = models[0]["id"] if models else None
        if enabled and model_id is None:
            raise InputError(f"joint {joint_id!r} has no identified model to compensate with")
        with self._tx() as c:
            c.execute("INSERT OR REPLACE INTO compensation (joint_id, enabled, model_id, updated) VALUES (?,?,?,?)",
                      (joint_id, int(bool(enabled)), model_id, time.time()))
        return self.get_compensation(joint_id)


def _jsonable(x):
    try:
        import numpy as np
        if isinstance(x, np.generic):
            return x.item()
        if isinstance(x, np.ndarray):
            return x.tolist()
    except ImportError:
        pass
    return str(x)


def _run_dict(r) -> dict:
    d = dict(r)
    for k in ("config", "result"):
        d[k] = json.loads(d[k]) if d[k] else None
    return d


def _model_dict(r) -> dict:
    d = dict(r)
    d["params"] = json.loads(d["params"])
    d["report"] = json.loads(d["report"]) if d["report"] else None
    return d
