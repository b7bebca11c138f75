"""Where a health history lives: an SQLite file, or a database named by a URL.

:class:`~pdmkit.experiments._monitor_history.HealthHistory` holds the logic (schema
checks, exactly-once files, the alarm latch); this module is the thin layer under it:
create the tables, one transaction, run a statement. A plain path goes through the
standard library's ``sqlite3`` (nothing else imported); a URL (``sqlite:///h.sqlite``,
``postgresql+psycopg://user@host/db``) goes through SQLAlchemy Core, the optional
extra ``pdmkit[db]``.

Both take the same SQL: named parameters (``:name``), identifiers written ``{name}``
and quoted by the backend where its database reserves them (``key`` in MySQL), no
statement that only one database knows. A write transaction is serialised: ``BEGIN
IMMEDIATE`` on SQLite (a file or a ``sqlite://`` URL), ``SERIALIZABLE`` isolation on
other databases, so that "check, then insert" cannot interleave with another writer.

A URL's password never appears in a message: :func:`mask_url` replaces it by ``***``.

Examples
--------
>>> mask_url("postgresql+psycopg://scada:s3cret@db.plant/history")
'postgresql+psycopg://scada:***@db.plant/history'
>>> db_target("sqlite:///h.sqlite"), db_target("h.sqlite") == Path("h.sqlite")
('sqlite:///h.sqlite', True)
"""

from __future__ import annotations

import contextlib
import os
import sqlite3
from collections.abc import Iterator, Mapping, Sequence
from importlib import import_module
from pathlib import Path
from typing import Any
from urllib.parse import unquote

from pdmkit.errors import DataError, MissingExtraError

__all__ = ["SQLAlchemyURL", "SQLiteFile", "db_target", "is_url", "mask_url"]

#: the schema's column kinds -> SQLite's declared types
SQLITE_TYPES = {"text": "TEXT", "real": "REAL", "integer": "INTEGER"}

#: tables: name -> ((column, kind), ...); keys: name -> primary-key columns
Tables = Mapping[str, Sequence[tuple[str, str]]]
Keys = Mapping[str, Sequence[str]]
#: one statement's parameters, or a list of them (one row each)
Params = Mapping[str, Any] | Sequence[Mapping[str, Any]] | None


def is_url(target: Any) -> bool:
    """Whether ``target`` names a database by URL (a string with ``://``)."""
    return isinstance(target, str) and "://" in target


def db_target(text: str) -> str | Path:
    """``--db``'s value: a URL stays a string (a path would fold its ``//``)."""
    return text if is_url(text) else Path(text)


def _password(url: str) -> tuple[str, str] | None:
    """(where the password starts, where it ends) in ``url``, or None."""
    head, sep, rest = url.partition("://")
    authority = rest.split("?", 1)[0]
    at = authority.rfind("@")
    user, colon, _ = authority[: max(at, 0)].partition(":")
    if not sep or at < 0 or not colon or "/" in user:
        return None
    start = len(head) + len(sep) + len(user) + 1
    return start, len(head) + len(sep) + at


def mask_url(url: str) -> str:
    """``url`` with its password (if any) replaced by ``***``."""
    span = _password(url)
    return url if span is None else url[: span[0]] + "***" + url[span[1] :]


class _Quoted(dict):
    """``str.format_map`` helper: ``{name}`` -> the name as the database quotes it."""

    def __init__(self, quote) -> None:
        super().__init__()
        self.quote = quote

    def __missing__(self, name: str) -> str:
        return self.quote(name)


class _Backend:
    """What both backends share: naming and SQL templates."""

    #: who answered, in messages ("SQLite said: ...")
    said = "the database"
    #: the errors that mean "not a pdmkit health history" when opening
    errors: tuple[type[BaseException], ...] = ()
    name: str

    def quote(self, name: str) -> str:
        """``name`` as an identifier of this database (quoted where reserved)."""
        return name

    def sql(self, template: str) -> str:
        """``template`` with each ``{identifier}`` quoted for this database."""
        return template.format_map(_Quoted(self.quote))


class SQLiteFile(_Backend):
    """A history file through the standard library's ``sqlite3``.

    One connection in autocommit mode: a statement outside :meth:`transaction` commits
    on its own; :meth:`transaction` takes the write lock first (``BEGIN IMMEDIATE``).
    """

    said = "SQLite"
    errors = (sqlite3.DatabaseError,)

    def __init__(self, path: str | os.PathLike, read_only: bool = False) -> None:
        self.name = str(path)
        if read_only:  # never creates the file nor writes to it
            uri = Path(path).resolve().as_uri() + "?mode=ro"
            self._db = sqlite3.connect(uri, uri=True, timeout=30.0, isolation_level=None)
        else:
            self._db = sqlite3.connect(path, timeout=30.0, isolation_level=None)

    def create(self, tables: Tables, keys: Keys) -> None:
        """Create the tables that are missing (``CREATE TABLE IF NOT EXISTS``)."""
        statements = []
        for table, columns in tables.items():
            key = tuple(keys[table])
            parts = [
                f"{name} {SQLITE_TYPES[kind]}"
                + (" PRIMARY KEY" if key == (name,) else " NOT NULL" * (name in key))
                for name, kind in columns
            ]
            parts += [f"PRIMARY KEY ({', '.join(key)})"] * (len(key) > 1)
            statements.append(f"CREATE TABLE IF NOT EXISTS {table} ({', '.join(parts)});")
        self._db.executescript("\n".join(statements))

    @contextlib.contextmanager
    def transaction(self) -> Iterator[None]:
        """One IMMEDIATE transaction: committed when the block ends, else rolled back."""
        self._db.execute("BEGIN IMMEDIATE")
        try:
            yield
        except BaseException:
            self._db.execute("ROLLBACK")
            raise
        self._db.execute("COMMIT")

    def query(self, sql: str, params: Params = None) -> tuple[list[str], list[tuple]]:
        """(column names, rows) of a SELECT."""
        cursor = self._db.execute(sql, params or {})
        return [d[0] for d in cursor.description], cursor.fetchall()

    def execute(self, sql: str, params: Params = None) -> None:
        """Run a statement; a list of parameter sets runs it once per set."""
        if isinstance(params, Sequence):
            self._db.executemany(sql, params)
        else:
            self._db.execute(sql, params or {})

    def close(self) -> None:
        """Close the connection."""
        self._db.close()


def _import_sqlalchemy(name: str):
    """SQLAlchemy, or one line naming the history's URL and the extra to install."""
    try:
        return import_module("sqlalchemy")
    except ModuleNotFoundError as exc:
        if exc.name != "sqlalchemy":
            raise
        raise MissingExtraError(
            f"the health history at {name} (a URL) needs sqlalchemy: "
            "pip install 'pdmkit[db]'",
            name="sqlalchemy",
        ) from None


class SQLAlchemyURL(_Backend):
    """A history in the database a SQLAlchemy URL names (SQLAlchemy Core, 2.x API).

    Every error of SQLAlchemy or of the database driver becomes one
    :class:`~pdmkit.errors.DataError` line naming the URL with its password masked
    (an absent driver module: :class:`~pdmkit.errors.MissingExtraError`).
    """

    def __init__(self, url: str, read_only: bool = False) -> None:
        # read_only: the history only reads (tables are not created, nothing written)
        self.name = mask_url(url)
        span = _password(url)
        secret = "" if span is None else url[span[0] : span[1]]
        self._secrets = [s for s in {secret, unquote(secret)} if s]
        self._sa = _import_sqlalchemy(self.name)
        self._conn: Any = None
        with self._errors("opening it"):
            parsed = self._sa.engine.make_url(url)
            sqlite = parsed.get_backend_name() == "sqlite"
        if read_only and sqlite and parsed.database not in (None, "", ":memory:"):
            if not Path(parsed.database).is_file():  # connecting would create it
                raise DataError(f"{self.name}: no such health history file")
        with self._errors("opening it"):
            args = {"connect_args": {"timeout": 30.0}} if sqlite else {}
            try:
                self._engine = self._sa.create_engine(url, **args)
            except ImportError as exc:  # the dialect's driver module is absent
                raise MissingExtraError(
                    f"the health history at {self.name} needs the database driver "
                    f"module {exc.name or exc}, which is not installed",
                    name=exc.name,
                ) from None
        if sqlite:  # SQLAlchemy's recipe: the driver's own BEGIN off, ours on
            self._sa.event.listen(self._engine, "connect", _driver_autocommit)
            self._sa.event.listen(self._engine, "begin", _sqlite_begin)
            self._write_options = {"pdmkit_write": True}
        else:
            self._write_options = {"isolation_level": "SERIALIZABLE"}
        self.quote = self._engine.dialect.identifier_preparer.quote

    def _line(self, exc: BaseException) -> str:
        """The database's (or SQLAlchemy's) first line about ``exc``, no password."""
        text = str(getattr(exc, "orig", None) or exc).strip()
        line = text.splitlines()[0] if text else type(exc).__name__
        for secret in self._secrets:
            line = line.replace(secret, "***")
        return line

    @contextlib.contextmanager
    def _errors(self, doing: str) -> Iterator[None]:
        try:
            yield
        except self._sa.exc.SQLAlchemyError as exc:
            raise DataError(
                f"the health history at {self.name}: {doing} failed: {self._line(exc)}"
            ) from None

    @contextlib.contextmanager
    def _connection(self) -> Iterator[Any]:
        """The transaction's connection, else a fresh one for this statement."""
        if self._conn is not None:
            yield self._conn
            return
        with self._engine.connect() as conn:
            yield conn

    def create(self, tables: Tables, keys: Keys) -> None:
        """Create the tables that are missing, in this database's types.

        A text column in a primary key is ``VARCHAR(255)`` (MySQL indexes no
        ``TEXT``); ``real`` is double precision (PostgreSQL's ``REAL`` is 4 bytes).
        """
        sa = self._sa
        types = {"text": sa.Text, "real": sa.Double, "integer": sa.Integer}
        metadata = sa.MetaData()
        for table, columns in tables.items():
            key = tuple(keys[table])
            sa.Table(table, metadata, *(
                sa.Column(name, sa.String(255) if kind == "text" and name in key
                          else types[kind](), primary_key=name in key,
                          autoincrement=False)
                for name, kind in columns))  # fmt: skip
        with self._errors("creating its tables"):
            metadata.create_all(self._engine)

    @contextlib.contextmanager
    def transaction(self) -> Iterator[None]:
        """One serialised transaction: committed when the block ends, else rolled back."""
        with self._errors("a transaction"), self._engine.connect() as conn:
            conn.execution_options(**self._write_options)
            with conn.begin():
                self._conn = conn
                try:
                    yield
                finally:
                    self._conn = None

    def query(self, sql: str, params: Params = None) -> tuple[list[str], list[tuple]]:
        """(column names, rows) of a SELECT."""
        with self._errors("a query"), self._connection() as conn:
            result = conn.execute(self._sa.text(sql), params or {})
            return list(result.keys()), [tuple(row) for row in result]

    def execute(self, sql: str, params: Params = None) -> None:
        """Run a statement; a list of parameter sets runs it once per set."""
        if isinstance(params, Sequence) and not params:
            return
        with self._errors("a statement"), self._connection() as conn:
            conn.execute(self._sa.text(sql), params or {})

    def close(self) -> None:
        """Release the engine's connections."""
        self._engine.dispose()


def _driver_autocommit(dbapi_connection, connection_record) -> None:
    """sqlite3 must not emit its own (deferred) BEGIN: :func:`_sqlite_begin` does."""
    dbapi_connection.isolation_level = None


def _sqlite_begin(conn) -> None:
    """A write transaction takes SQLite's write lock at once; a read does not."""
    write = conn.get_execution_options().get("pdmkit_write", False)
    conn.exec_driver_sql("BEGIN IMMEDIATE" if write else "BEGIN")
