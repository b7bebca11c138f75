"""Everything pdmkit writes into a user's output folder (``--out``), one way.

An output folder belongs to the user. A run writes its results *beside* whatever is
there, replacing only the files of its command (:data:`OUTPUTS`, a fixed list of names)
and never removing anything else; what pdmkit needs for itself lives in ``.pdmkit/``
(and, for ``features``, the resumable partition store ``run/``)::

    OUT/
      features.parquet, summary.json, report.html, ...   the command's files
      run/                     features: committed partitions (resume after a kill)
      .pdmkit/lock             held (flock) by the run writing into OUT; holds its pid
      .pdmkit/run.json         manifest of the last run committed here: run id,
                               command, every file with its SHA-256
      .pdmkit/staging-<id>/    a run's files being written (gone if the run dies)
      .pdmkit/commit-<id>/     a committed run whose files are being moved into OUT
      .pdmkit/cache/           caches (e.g. the simulated air-leak tables)

A run (:class:`OutputRun`) stages all its files in ``.pdmkit/staging-<id>/`` and writes
a manifest there; the commit point is one ``rename`` of that folder to
``.pdmkit/commit-<id>/``; then each file is moved into OUT with ``os.replace``,
``.pdmkit/run.json`` is written and the commit folder removed. The next run on OUT,
under the lock, first finishes the moves of a commit folder it finds (roll forward) and
removes the staging folders and temporaries of dead runs. So whenever a kill strikes,
once any later pdmkit run has opened OUT the folder holds one run's files, all of them.

Every warning raised while a run is open (Python ``warnings``: pdmkit's own, numpy's,
scikit-learn's) is collected, one line each, and written into the run's JSON summaries
under ``"warnings"``, next to ``"run_id"``.
"""

from __future__ import annotations

import contextlib
import datetime as _dt
import json
import math
import os
import secrets
import shutil
import sys
import time
import warnings
from collections.abc import Callable, Iterable, Iterator, Mapping
from pathlib import Path
from typing import Any

from pdmkit._atomic import atomic_path, remove_stale_temporaries
from pdmkit._checks import file_sha256
from pdmkit._output_folder import (
    MAIN_JSON,
    OUTPUTS,
    PRIVATE,
    check_output_folder,
    local_paths,
    real_path,
)
from pdmkit.errors import DataError

__all__ = [
    "MAIN_JSON",
    "OUTPUTS",
    "OutputRun",
    "collect_warnings",
    "recover",
    "to_jsonable",
    "write_json_file",
]

#: Seconds a run waits for another run to release an output folder before refusing
#: (environment variable ``PDMKIT_LOCK_WAIT`` overrides it).
LOCK_WAIT_S = 30.0

_FORMAT = "pdmkit.output"


# --------------------------------------------------------------------------- JSON
def to_jsonable(value: Any) -> Any:
    """Return ``value`` as plain JSON types: NaN/inf -> None, numpy -> Python.

    Examples
    --------
    >>> import numpy as np
    >>> to_jsonable({"a": np.float64("nan"), "b": np.arange(2), "c": (np.int64(3),)})
    {'a': None, 'b': [0, 1], 'c': [3]}
    """
    if isinstance(value, Mapping):
        return {str(k): to_jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple | set | frozenset):
        return [to_jsonable(v) for v in value]
    if hasattr(value, "tolist") and hasattr(value, "dtype"):  # numpy array or scalar
        return to_jsonable(value.tolist())
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if value is None or isinstance(value, bool | int | str):
        return value
    if isinstance(value, os.PathLike):
        return os.fspath(value)
    import pandas as pd

    if value is pd.NA or value is pd.NaT:
        return None
    if isinstance(value, pd.Timestamp | _dt.datetime | _dt.date):
        return value.isoformat()
    raise TypeError(
        f"cannot write {type(value).__name__!r} values to JSON; convert them to numbers, "
        "strings, lists or dicts first"
    )


def _dumps(data: Any) -> str:
    return json.dumps(to_jsonable(data), indent=2, allow_nan=False) + "\n"


# --------------------------------------------------------------------------- warnings
_COLLECTORS: list[list[str]] = []


def _one_line(message: Warning | str, category: type[Warning]) -> str:
    text = str(message).strip().splitlines()
    return f"{category.__name__}: {text[0].strip() if text else ''}"


@contextlib.contextmanager
def collect_warnings() -> Iterator[list[str]]:
    """Collect the warnings shown inside the block, one line each, deduplicated.

    The warnings are still shown as usual (the filters in force decide which); the
    yielded list fills as they come. A block inside another starts with what the outer
    one had collected, so a run opened inside a command sees the command's warnings.

    Examples
    --------
    >>> import warnings
    >>> with collect_warnings() as found:
    ...     warnings.warn("the fit stopped early", RuntimeWarning, stacklevel=1)
    ...     warnings.warn("the fit stopped early", RuntimeWarning, stacklevel=1)
    >>> found
    ['RuntimeWarning: the fit stopped early']
    """
    records = list(_COLLECTORS[-1]) if _COLLECTORS else []
    with warnings.catch_warnings():  # puts showwarning (and the filters) back after
        previous = warnings.showwarning

        def hook(message, category, filename, lineno, file=None, line=None):
            text = _one_line(message, category)
            for found in _COLLECTORS:
                if text not in found:
                    found.append(text)
            previous(message, category, filename, lineno, file, line)

        warnings.showwarning = hook
        _COLLECTORS.append(records)
        try:
            yield records
        finally:
            for i in range(len(_COLLECTORS) - 1, -1, -1):
                if _COLLECTORS[i] is records:
                    del _COLLECTORS[i]
                    break


def write_json_file(
    data: Mapping[str, Any],
    path: str | os.PathLike,
    *,
    inputs: Iterable[Any] = (),
    command: str = "rul",
) -> Path:
    r"""Write ``data`` as JSON to ``path`` atomically, after the checks of ``--json``.

    For answers that have no output folder (``pdmkit rul --trained``): ``path`` must
    not be a folder or one of the ``inputs``.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "a.json"
    >>> p = write_json_file({"x": float("nan")}, path)
    >>> p.read_text()
    '{\n  "x": null\n}\n'
    """
    check_output_folder(None, command, inputs=inputs, json_path=path)
    text = _dumps(data)
    with atomic_path(path) as tmp:
        tmp.write_text(text, encoding="utf-8")
    return Path(path)


# --------------------------------------------------------------------------- locking
try:
    import fcntl
except ImportError:  # pragma: no cover - Windows
    fcntl = None


def _try_lock(fd: int) -> bool:
    if fcntl is not None:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except (BlockingIOError, PermissionError):
            return False
        return True
    import msvcrt  # pragma: no cover

    try:  # pragma: no cover
        msvcrt.locking(fd, msvcrt.LK_NBLCK, 1)
    except OSError:  # pragma: no cover
        return False
    return True  # pragma: no cover


def _unlock(fd: int) -> None:
    try:
        if fcntl is not None:
            fcntl.flock(fd, fcntl.LOCK_UN)
        else:  # pragma: no cover
            import msvcrt

            os.lseek(fd, 0, os.SEEK_SET)
            msvcrt.locking(fd, msvcrt.LK_UNLCK, 1)
    finally:
        os.close(fd)


def _holder(path: Path) -> str:
    try:
        info = json.loads(path.read_text())
        return (
            f"pdmkit {info.get('command')} run, pid {info.get('pid')}, since "
            f"{info.get('started')}"
        )
    except (OSError, ValueError, AttributeError):
        return "another pdmkit run"


def _lock_wait() -> float:
    text = os.environ.get("PDMKIT_LOCK_WAIT")
    if text:
        try:
            return max(0.0, float(text))
        except ValueError:
            raise DataError(
                f"PDMKIT_LOCK_WAIT must be a number of seconds, got {text!r}"
            ) from None
    return LOCK_WAIT_S


def _acquire(out: Path, info: dict, wait: float | None) -> int:
    """Lock ``out`` (``.pdmkit/lock``); wait up to ``wait`` s for another run."""
    path = out / PRIVATE / "lock"
    fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o666)
    wait = _lock_wait() if wait is None else wait
    deadline = time.monotonic() + wait
    told = False
    while not _try_lock(fd):
        if time.monotonic() >= deadline:
            os.close(fd)
            raise DataError(
                f"output folder {out} is in use by {_holder(path)} (waited {wait:g} s); "
                "let it finish, or write to another --out folder"
            )
        if not told:
            print(
                f"pdmkit: {out} is in use by {_holder(path)}; waiting up to {wait:g} s",
                file=sys.stderr,
                flush=True,
            )
            told = True
        time.sleep(0.05)
    os.ftruncate(fd, 0)
    os.lseek(fd, 0, os.SEEK_SET)
    os.write(fd, (json.dumps(info) + "\n").encode())
    return fd


# --------------------------------------------------------------------------- commit
def _fsync(path: Path) -> None:
    flags = os.O_RDONLY | (getattr(os, "O_DIRECTORY", 0) if path.is_dir() else 0)
    try:
        fd = os.open(path, flags)
    except OSError:  # pragma: no cover - platforms that cannot open folders
        return
    try:
        os.fsync(fd)
    except OSError:  # pragma: no cover
        pass
    finally:
        os.close(fd)


def _roll_forward(out: Path, commit: Path) -> None:
    """Move a committed run's files into ``out``; write ``run.json``; drop ``commit``."""
    manifest = json.loads((commit / "manifest.json").read_text())
    allowed = set(OUTPUTS.get(manifest.get("command"), ()))
    for name in manifest["files"]:
        if name not in allowed:  # never move anything but the command's own names
            raise DataError(f"{commit}/manifest.json names {name!r}, not a pdmkit output")
        src = commit / name
        if os.path.lexists(src):
            dst = out / name
            dst.parent.mkdir(parents=True, exist_ok=True)
            os.replace(src, dst)
    manifest["committed"] = _now()
    with atomic_path(out / PRIVATE / "run.json") as tmp:
        tmp.write_text(json.dumps(manifest, indent=2) + "\n")
    shutil.rmtree(commit, ignore_errors=True)


def recover(out: str | os.PathLike) -> list[str]:
    """Finish or clean up what killed runs left in ``out``; hold its lock to call this.

    A commit folder (a run killed after its commit point) is rolled forward: its files
    are moved into ``out``. Staging folders (runs killed before it) and temporaries of
    dead processes are removed. Returns one line per action.
    """
    out = Path(out)
    private = out / PRIVATE
    done = []
    if not private.is_dir():
        return done
    commits = sorted(private.glob("commit-*"), key=lambda p: p.stat().st_mtime_ns)
    for commit in commits:
        try:
            _roll_forward(out, commit)
            done.append(f"finished moving the files of interrupted run {commit.name[7:]}")
        except (OSError, ValueError, KeyError, TypeError) as exc:
            if (commit / "manifest.json").is_file():
                raise DataError(
                    f"{out}: cannot finish the interrupted run in {commit} ({exc}); "
                    "fix the cause (permissions, a folder in the way) and run again"
                ) from None
            shutil.rmtree(commit, ignore_errors=True)  # pragma: no cover - no manifest
    for staging in private.glob("staging-*"):
        shutil.rmtree(staging, ignore_errors=True)
        done.append(f"removed {staging.name} of a run that did not finish")
    legacy = {Path(n).name for names in OUTPUTS.values() for n in names}
    folders = {out, private, private / "cache"}
    folders |= {out / Path(n).parent for names in OUTPUTS.values() for n in names}
    for folder in folders:
        for path in remove_stale_temporaries(folder, legacy):
            done.append(f"removed the leftover {path.name}")
    for sub in ("run", "run/parts"):  # the features partition store
        for path in remove_stale_temporaries(out / sub):
            done.append(f"removed the leftover {sub}/{path.name}")
    return done


def _now() -> str:
    return _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds")


class _Sink:
    """Where a workflow registers its files: a run, or a sub-folder of one."""

    def __init__(self, run: OutputRun, prefix: str = ""):
        self._run = run
        self._prefix = prefix

    def _name(self, name: str) -> str:
        return f"{self._prefix}{name}"

    @property
    def folder(self) -> Path:
        """The final folder of these files."""
        return self._run.out / self._prefix if self._prefix else self._run.out

    @property
    def run_id(self) -> str:
        return self._run.id

    @property
    def cache(self) -> Path:
        """``OUT/.pdmkit/cache``: where a workflow may keep what it can compute again."""
        return self._run.out / PRIVATE / "cache"

    def path(self, name: str) -> Path:
        """The final path of ``name`` (once the run is committed)."""
        return self._run.out / self._name(name)

    def view(self, prefix: str) -> _Sink:
        """The files of a sub-folder (``prefix`` like ``"rul"``)."""
        return _Sink(self._run, f"{self._prefix}{prefix.strip('/')}/")

    def add_file(self, name: str, write: Callable[[Path], Any]) -> Path:
        """Register ``name``; ``write(path)`` writes it (at commit, into staging)."""
        return self._run._add(self._name(name), "file", write)

    def add_text(self, name: str, text: str) -> Path:
        return self.add_file(name, lambda p: p.write_text(text, encoding="utf-8"))

    def add_parquet(self, name: str, table, **kwargs) -> Path:
        """Register a table (not to be changed until the commit) as Parquet."""
        self._run._frames[self._name(name)] = table
        return self.add_file(name, lambda p: table.to_parquet(p, **kwargs))

    def frame(self, name: str):
        """The table registered as ``name`` with :meth:`add_parquet`."""
        return self._run._frames[self._name(name)]

    def add_csv(self, name: str, table, **kwargs) -> Path:
        return self.add_file(name, lambda p: table.to_csv(p, **kwargs))

    def add_report(self, name: str, report) -> Path:
        """Register an HTML report (with ``write(path)``); it carries the run id."""

        def write(path: Path) -> None:
            report.run_id = self._run.id
            report.write(path)

        return self.add_file(name, write)

    def add_json(self, name: str, data: dict) -> Path:
        """Register a JSON summary; at commit it gains ``run_id`` and ``warnings``."""
        return self._run._add(self._name(name), "json", data)


class OutputRun(_Sink):
    """One run's results, written into a user's output folder beside what is there.

    Construct it before the work starts (it checks ``out``, ``json_path`` and the
    inputs with :func:`check_output_folder`), enter it around the work (it collects
    warnings), register the files as they become ready (``add_parquet``,
    ``add_report``, ``add_json``, ...; written only at commit) and call
    :meth:`commit`. Leaving the block without committing writes nothing.

    Parameters
    ----------
    out : path
        The output folder (created on commit).
    command : str
        A key of :data:`OUTPUTS`: the names this run may write.
    inputs : iterable of path, optional
        Files and folders the run reads (never overwritten; see
        :func:`check_output_folder`).
    json_path : path, optional
        Also write the command's JSON summary (:data:`MAIN_JSON`) here.
    wait : float, optional
        Seconds to wait for another run holding ``out`` (default :data:`LOCK_WAIT_S`,
        or ``$PDMKIT_LOCK_WAIT``); then a one-line error naming its pid.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> out = pathlib.Path(tempfile.mkdtemp())
    >>> _ = (out / "notes.txt").write_text("mine")
    >>> with OutputRun(out, "classify") as run:
    ...     _ = run.add_text("report.html", "<html></html>")
    ...     _ = run.add_json("summary.json", {"accuracy": 0.9})
    ...     manifest = run.commit()
    >>> sorted(p.name for p in out.iterdir())
    ['.pdmkit', 'notes.txt', 'report.html', 'summary.json']
    >>> json.loads((out / "summary.json").read_text())["warnings"]
    []
    """

    def __init__(
        self,
        out: str | os.PathLike,
        command: str,
        *,
        inputs: Iterable[Any] = (),
        json_path: str | os.PathLike | None = None,
        wait: float | None = None,
    ) -> None:
        if command not in OUTPUTS:
            raise ValueError(f"command must be one of {sorted(OUTPUTS)}, got {command!r}")
        out = Path(out)
        self.out = out
        self.command = command
        self.json_path = None if json_path is None else Path(json_path)
        self.inputs = list(inputs)
        self.wait = wait
        stamp = _dt.datetime.now(_dt.timezone.utc).strftime("%Y%m%dT%H%M%SZ")
        self.id = f"{stamp}-{os.getpid()}-{secrets.token_hex(3)}"
        self.started = _now()
        self.committed = False
        self._entries: dict[str, tuple[str, Any]] = {}
        self._frames: dict[str, Any] = {}
        self._fd: int | None = None
        self._staging: Path | None = None
        self._collector: contextlib.ExitStack | None = None
        self._warnings: list[str] = []
        super().__init__(self, "")
        check_output_folder(out, command, inputs=self.inputs, json_path=self.json_path)

    def __repr__(self) -> str:
        return f"OutputRun({str(self.out)!r}, {self.command!r}, id={self.id!r})"

    # ------------------------------------------------------------------ context
    def __enter__(self) -> OutputRun:
        self._collector = contextlib.ExitStack()
        self._warnings = self._collector.enter_context(collect_warnings())
        return self

    def __exit__(self, *exc) -> None:
        try:
            if self._staging is not None and self._staging.exists():
                shutil.rmtree(self._staging, ignore_errors=True)
        finally:
            self._release()
            if self._collector is not None:
                self._collector.close()
                self._collector = None

    @property
    def warnings(self) -> list[str]:
        """The warnings collected so far (one line each, first occurrence first)."""
        return list(self._warnings)

    # ------------------------------------------------------------------ files
    def _add(self, name: str, kind: str, payload: Any) -> Path:
        if self.committed:
            raise RuntimeError(f"{self!r} is already committed")
        if name not in OUTPUTS[self.command]:
            raise ValueError(
                f"{self.command} does not write {name!r}; its files: "
                f"{list(OUTPUTS[self.command])}"
            )
        self._entries[name] = (kind, payload)
        return self.out / name

    # ------------------------------------------------------------------ lock
    def open(self) -> OutputRun:
        """Create ``out`` and lock it (waiting for another run; see ``wait``).

        Finishes or cleans up what killed runs left (:func:`recover`). Called by
        :meth:`commit`; call it early to hold the folder for the whole run (as
        ``features`` does while its partition store fills).
        """
        if self._fd is not None:
            return self
        check_output_folder(self.out, self.command, json_path=self.json_path)
        try:
            (self.out / PRIVATE).mkdir(parents=True, exist_ok=True)
        except (FileExistsError, NotADirectoryError):
            raise DataError(
                f"output folder {self.out} cannot be created: a file is in the way; "
                "name a folder for --out"
            ) from None
        info = {"pid": os.getpid(), "command": self.command, "run_id": self.id}
        info["started"] = self.started
        self._fd = _acquire(self.out, info, self.wait)
        try:
            for line in recover(self.out):
                print(f"pdmkit: {self.out}: {line}", file=sys.stderr, flush=True)
        except BaseException:
            self._release()
            raise
        return self

    def _release(self) -> None:
        if self._fd is not None:
            fd, self._fd = self._fd, None
            _unlock(fd)

    # ------------------------------------------------------------------ commit
    def commit(self, then: Callable[[], Any] | None = None) -> dict:
        """Write every registered file, all at once; return the run's manifest.

        Files are written into a staging folder, then the run is committed by one
        rename and moved into ``out`` (see the module notes); a copy of the JSON
        summary goes to ``json_path``; ``then()`` runs, still under the lock; the lock
        is released.
        """
        if self.committed:
            raise RuntimeError(f"{self!r} is already committed")
        if not self._entries:
            raise RuntimeError(f"{self!r} has no files to commit")
        self.open()
        try:
            try:
                manifest = self._stage()
                commit = self.out / PRIVATE / f"commit-{self.id}"
                os.rename(self._staging, commit)  # the commit point
            except BaseException:  # nothing in OUT changed; drop the half-staged files
                if self._staging is not None:
                    shutil.rmtree(self._staging, ignore_errors=True)
                raise
            finally:
                self._staging = None
            _fsync(self.out / PRIVATE)
            _roll_forward(self.out, commit)
            self.committed = True
            self._copy_json()
            if then is not None:
                then()
        finally:
            self._release()
        return manifest

    def _stage(self) -> dict:
        staging = self.out / PRIVATE / f"staging-{self.id}"
        staging.mkdir()
        self._staging = staging
        order = [n for n in OUTPUTS[self.command] if n in self._entries]
        files = [n for n in order if self._entries[n][0] == "file"]
        jsons = [n for n in order if self._entries[n][0] == "json"]
        for name in files:  # data and reports first: their warnings reach the JSON
            target = staging / name
            target.parent.mkdir(parents=True, exist_ok=True)
            self._entries[name][1](target)
        found = self.warnings
        for name in jsons:
            data = self._entries[name][1]
            data["run_id"] = self.id
            data["warnings"] = list(found)
            target = staging / name
            target.parent.mkdir(parents=True, exist_ok=True)
            target.write_text(_dumps(data), encoding="utf-8")
        manifest = {
            "format": _FORMAT,
            "format_version": 1,
            "run_id": self.id,
            "command": self.command,
            "pid": os.getpid(),
            "started": self.started,
            "inputs": [os.fspath(p) for p in local_paths(self.inputs)],
            "files": {},
            "warnings": found,
        }
        for name in order:
            path = staging / name
            if not path.is_file():
                raise RuntimeError(f"the writer of {name} wrote no file")
            manifest["files"][name] = {
                "sha256": file_sha256(path),
                "bytes": path.stat().st_size,
            }
            _fsync(path)
        (staging / "manifest.json").write_text(json.dumps(manifest, indent=2) + "\n")
        _fsync(staging / "manifest.json")
        _fsync(staging)
        return manifest

    def _copy_json(self) -> None:
        if self.json_path is None:
            return
        main = MAIN_JSON[self.command]
        if main not in self._entries:
            return
        source = self.out / main
        if real_path(self.json_path) == real_path(source):
            return
        with atomic_path(self.json_path) as tmp:
            shutil.copyfile(source, tmp)
