"""The event store of a fleet: one SQLite file, ``<out>/events.sqlite``, that pandas, DuckDB and the sqlite3 shell read.

Tables (docs/design.md §10.2)::

    recordings  name (key), stamp, status ok|failed, message, events, samples, bytes_read, seconds, femref_version,
                start, track, event_file
    events      one row per event and coupler, key (event_key, coupler): :data:`EVENT_COLUMNS`
    estimates   one row per event, coupler and estimator, key (event_key, coupler, estimator): :data:`ESTIMATE_COLUMNS`

Times are UTC text ``YYYY-MM-DD HH:MM:SS.ffffff``, which sorts as time and compares with SQLite's own
``datetime('now', '-7 days')``; a missing number is NULL (NaN in pandas); ``recording`` on the events and
estimates rows ties them to their recording.

Writes: only :class:`EventStore` writes, in one transaction per recording (:meth:`EventStore.put`: its old rows
deleted, its new rows and its ``recordings`` row inserted, committed together), so a reader or a kill sees a
recording whole or not at all, and the keys make a duplicate row impossible. The journal is SQLite's rollback
journal (``journal_mode=DELETE``), not WAL: there is one writer (the client of a fleet run, never a worker),
transactions are few and short, and without WAL the store is one file that can be copied or read from a network
share (WAL needs shared memory between the processes that open it, which network file systems do not give).
A reader waits at most :data:`BUSY_TIMEOUT_S` for a commit.
"""

from __future__ import annotations

import math
import sqlite3
from collections.abc import Iterator, Mapping, Sequence
from contextlib import closing, contextmanager
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    import pandas

__all__ = ["ESTIMATE_COLUMNS", "EVENT_COLUMNS", "STORE_NAME", "EventStore", "RecordingRow", "StoreError", "read_estimates", "read_events",
           "read_recordings", "sql_time"]

#: The store's file name in a fleet's output folder.
STORE_NAME = "events.sqlite"
#: ``PRAGMA application_id`` of a femref event store ("fmrf") and its layout version (``PRAGMA user_version``).
APPLICATION_ID = 0x666D7266
SCHEMA_VERSION = 1
#: Longest a connection waits for another's transaction (s).
BUSY_TIMEOUT_S = 30.0

#: The events table: column → pandas dtype of :func:`read_events` (``str``: text; the SQL type follows).
EVENT_COLUMNS: dict[str, str] = {
    "event_key": "str", "recording": "str", "event_index": "int64", "time": "datetime64[ns, UTC]", "track": "str", "files": "str",
    "cars": "str", "coupler": "str", "car_front": "str", "car_rear": "str", "gear": "str", "event_type": "str",
    "closing_speed": "float64", "closing_speed_lower": "float64", "closing_speed_upper": "float64", "estimator": "str",
    "peak_force": "float64", "peak_force_lower": "float64", "peak_force_upper": "float64", "alarm_limit": "float64", "alarm": "str",
    "closure_force": "float64", "closure_status": "str", "wear_limit": "float64", "wear": "str", "flags": "str", "femref_version": "str",
    "calibration": "str", "network": "str", "histories": "str",
}
#: The estimates table: column → pandas dtype of :func:`read_estimates`.
ESTIMATE_COLUMNS: dict[str, str] = {
    "event_key": "str", "coupler": "str", "estimator": "str", "status": "str", "peak_force": "float64", "lower": "float64",
    "upper": "float64", "time_of_peak": "float64",
}
#: The recordings table: column → SQL type.
RECORDING_COLUMNS: dict[str, str] = {
    "name": "TEXT PRIMARY KEY", "stamp": "TEXT NOT NULL", "status": "TEXT NOT NULL CHECK (status IN ('ok', 'failed'))", "message": "TEXT NOT NULL",
    "events": "INTEGER NOT NULL", "samples": "INTEGER NOT NULL", "bytes_read": "INTEGER NOT NULL", "seconds": "REAL NOT NULL",
    "femref_version": "TEXT NOT NULL", "start": "TEXT NOT NULL", "track": "TEXT NOT NULL", "event_file": "TEXT NOT NULL",
}
_SQL_TYPES = {"str": "TEXT NOT NULL", "int64": "INTEGER NOT NULL", "float64": "REAL", "datetime64[ns, UTC]": "TEXT NOT NULL"}


class StoreError(ValueError):
    """A file at the store's path that is not a femref event store, or the store of another fleet."""


def sql_time(moment: datetime) -> str:
    """``moment`` as the store writes times: UTC text ``YYYY-MM-DD HH:MM:SS.ffffff``."""
    return moment.astimezone(timezone.utc).strftime("%Y-%m-%d %H:%M:%S.%f")


@dataclass(frozen=True)
class RecordingRow:
    """A ``recordings`` row: what was run of one recording and how it went (``seconds`` of its run on its worker)."""

    name: str
    stamp: str
    status: str
    message: str
    events: int
    samples: int
    bytes_read: int
    seconds: float
    femref_version: str
    start: str
    track: str
    event_file: str


def _schema() -> list[str]:
    def table(name: str, columns: Mapping[str, str], key: str) -> str:
        return f"CREATE TABLE {name} ({', '.join(f'{column} {kind}' for column, kind in columns.items())}{key})"

    events = {column: _SQL_TYPES[dtype] for column, dtype in EVENT_COLUMNS.items()}
    estimates = {"recording": "TEXT NOT NULL", **{column: _SQL_TYPES[dtype] for column, dtype in ESTIMATE_COLUMNS.items()}}
    return [
        "CREATE TABLE fleet (name TEXT NOT NULL)",
        table("recordings", RECORDING_COLUMNS, ""),
        table("events", events, ", PRIMARY KEY (event_key, coupler)"),
        table("estimates", estimates, ", PRIMARY KEY (event_key, coupler, estimator)"),
        "CREATE INDEX events_by_recording ON events (recording)",
        "CREATE INDEX events_by_time ON events (time)",
        "CREATE INDEX estimates_by_recording ON estimates (recording)",
    ]


def _connect(path: Path) -> sqlite3.Connection:
    """A connection with explicit transactions (``isolation_level=None``: :meth:`EventStore._transaction` begins them)."""
    return sqlite3.connect(path, timeout=BUSY_TIMEOUT_S, isolation_level=None)


def _check_store(connection: sqlite3.Connection, path: Path) -> None:
    try:
        application, version = (connection.execute(f"PRAGMA {pragma}").fetchone()[0] for pragma in ("application_id", "user_version"))
    except sqlite3.DatabaseError as error:
        raise StoreError(f"{path}: not a femref event store ({error})") from None
    if application != APPLICATION_ID:
        raise StoreError(f"{path}: not a femref event store (an SQLite file of another application); give another output folder")
    if version != SCHEMA_VERSION:
        raise StoreError(f"{path}: an event store of layout {version}; this femref reads layout {SCHEMA_VERSION}")


class EventStore:
    """The store at ``path``, made if absent, for the fleet ``fleet`` (module docstring); close it, or use it in ``with``."""

    def __init__(self, path: str | Path, fleet: str) -> None:
        self.path = Path(path)
        new = not self.path.exists() or self.path.stat().st_size == 0
        self.connection = _connect(self.path)
        try:
            if new:
                self._create(fleet)
            _check_store(self.connection, self.path)
            stored = self.connection.execute("SELECT name FROM fleet").fetchone()[0]
            if stored != fleet:
                raise StoreError(f"{self.path}: the store of fleet {stored!r}, not {fleet!r}; give another output folder")
        except BaseException:
            self.connection.close()
            raise

    def _create(self, fleet: str) -> None:
        with self._transaction() as cursor:
            for statement in _schema():
                cursor.execute(statement)
            cursor.execute("INSERT INTO fleet (name) VALUES (?)", (fleet,))
            cursor.execute(f"PRAGMA application_id = {APPLICATION_ID}")
            cursor.execute(f"PRAGMA user_version = {SCHEMA_VERSION}")

    @contextmanager
    def _transaction(self) -> Iterator[sqlite3.Cursor]:
        cursor = self.connection.cursor()
        cursor.execute("BEGIN IMMEDIATE")
        try:
            yield cursor
        except BaseException:
            cursor.execute("ROLLBACK")
            raise
        cursor.execute("COMMIT")

    def stamps(self) -> dict[str, tuple[str, str]]:
        """Recording name → (stamp, status) of every recording stored."""
        return {name: (stamp, status) for name, stamp, status in self.connection.execute("SELECT name, stamp, status FROM recordings")}

    def put(self, recording: RecordingRow, events: Sequence[Mapping[str, Any]], estimates: Sequence[Mapping[str, Any]]) -> None:
        """Replace everything stored of ``recording.name`` by ``recording`` and its rows, in one transaction."""
        with self._transaction() as cursor:
            for table in ("events", "estimates"):
                cursor.execute(f"DELETE FROM {table} WHERE recording = ?", (recording.name,))
            cursor.execute(f"INSERT OR REPLACE INTO recordings VALUES ({', '.join('?' * len(RECORDING_COLUMNS))})",
                           [getattr(recording, column) for column in RECORDING_COLUMNS])
            cursor.executemany(f"INSERT INTO events VALUES ({', '.join('?' * len(EVENT_COLUMNS))})",
                               [[_sql_value(row[column]) for column in EVENT_COLUMNS] for row in events])
            columns = ["recording", *ESTIMATE_COLUMNS]
            cursor.executemany(f"INSERT INTO estimates VALUES ({', '.join('?' * len(columns))})",
                               [[_sql_value(recording.name if column == "recording" else row[column]) for column in columns] for row in estimates])

    def close(self) -> None:
        self.connection.close()

    def __enter__(self) -> "EventStore":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _sql_value(value: Any) -> Any:
    """A row value as SQLite keeps it: a datetime as the store's UTC text, NaN as NULL."""
    if isinstance(value, datetime):
        return sql_time(value)
    if isinstance(value, float) and math.isnan(value):
        return None
    return value


def _read(path: str | Path, table: str, columns: Mapping[str, str], order: str) -> "pandas.DataFrame":
    import pandas as pd

    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no such event store")
    with closing(sqlite3.connect(f"{path.resolve().as_uri()}?mode=ro", uri=True, timeout=BUSY_TIMEOUT_S)) as connection:
        _check_store(connection, path)
        frame = pd.read_sql_query(f"SELECT {', '.join(columns)} FROM {table} ORDER BY {order}", connection)
    for column, dtype in columns.items():
        if dtype == "datetime64[ns, UTC]":
            frame[column] = pd.to_datetime(frame[column], utc=True, format="%Y-%m-%d %H:%M:%S.%f").astype(dtype)
        elif dtype == "str":
            frame[column] = frame[column].astype("str")
        else:
            frame[column] = frame[column].astype(dtype)
    return frame


def read_events(path: str | Path) -> "pandas.DataFrame":
    """Every event row of the store at ``path``, columns and dtypes :data:`EVENT_COLUMNS` (text as pandas' ``str``), in
    time order (then event key and coupler)."""
    return _read(path, "events", EVENT_COLUMNS, "time, event_key, coupler")


def read_estimates(path: str | Path) -> "pandas.DataFrame":
    """Every estimate row of the store at ``path``, columns and dtypes :data:`ESTIMATE_COLUMNS`, by event key, coupler
    and estimator."""
    return _read(path, "estimates", ESTIMATE_COLUMNS, "event_key, coupler, estimator")


def read_recordings(path: str | Path) -> "pandas.DataFrame":
    """The ``recordings`` table of the store at ``path`` (what was run of each recording and how), by name."""
    columns = {column: "int64" if kind.startswith("INTEGER") else "float64" if kind.startswith("REAL") else "str"
               for column, kind in RECORDING_COLUMNS.items()}
    return _read(path, "recordings", columns, "name")
