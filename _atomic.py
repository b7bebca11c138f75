"""Write files and directories so that a crash never leaves a half-written result.

Temporary names carry the writer's process id (``.NAME.PID.RANDOM.tmp``), so that
:func:`remove_stale_temporaries` can tell the leftovers of a killed writer from the
work of a live one.
"""

from __future__ import annotations

import contextlib
import os
import re
import shutil
import tempfile
from collections.abc import Iterable, Iterator
from pathlib import Path

__all__ = ["atomic_dir", "atomic_path", "pid_alive", "remove_stale_temporaries"]

#: ``.NAME.PID.RANDOM.tmp``: a temporary of :func:`atomic_path` / :func:`atomic_dir`.
_TMP = re.compile(r"^\.(?P<name>.+)\.(?P<pid>\d+)\.[A-Za-z0-9_]+\.tmp$")
#: ``.NAME.old-PID``: the old content :func:`atomic_dir` moved aside for a moment.
_OLD = re.compile(r"^\.(?P<name>.+)\.old-(?P<pid>\d+)$")


def _prefix(path: Path) -> str:
    return f".{path.name or 'out'}.{os.getpid()}."


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; rename it onto ``path`` on success.

    On an exception the temporary file is removed and ``path`` keeps what it held.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> target = pathlib.Path(tempfile.mkdtemp()) / "out.txt"
    >>> with atomic_path(target) as tmp:
    ...     _ = tmp.write_text("done")
    >>> target.read_text()
    'done'
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp_name = tempfile.mkstemp(prefix=_prefix(path), suffix=".tmp", dir=path.parent)
    os.close(fd)
    tmp = Path(tmp_name)
    try:
        yield tmp
        # mkstemp creates 0600; give the result the mode a plain open() would.
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()


@contextlib.contextmanager
def atomic_dir(path: str | os.PathLike) -> Iterator[Path]:
    """Yield a temporary directory beside ``path``; swap it in for ``path`` on success.

    An existing ``path`` is replaced *as a whole* only after the new content is
    complete; on an exception the temporary directory is removed and ``path`` is left as
    it was. Use it for folders pdmkit owns entirely (a Parquet dataset, a partition of a
    run), never for a user's output folder: whatever else that folder held would go
    (see :mod:`pdmkit._outputs`).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> target = pathlib.Path(tempfile.mkdtemp()) / "dataset"
    >>> with atomic_dir(target) as tmp:
    ...     _ = (tmp / "part-0.txt").write_text("x")
    >>> sorted(p.name for p in target.iterdir())
    ['part-0.txt']
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=_prefix(path), suffix=".tmp", dir=path.parent))
    try:
        yield tmp
        if path.exists():
            old = path.with_name(f".{path.name}.old-{os.getpid()}")
            os.replace(path, old)
            os.replace(tmp, path)
            shutil.rmtree(old, ignore_errors=True)
        else:
            os.replace(tmp, path)
    finally:
        if tmp.exists():
            shutil.rmtree(tmp, ignore_errors=True)


def pid_alive(pid: int) -> bool:
    """Whether a process with this id exists on this machine.

    Examples
    --------
    >>> pid_alive(os.getpid())
    True
    """
    if pid <= 0:
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # exists, owned by someone else
        return True
    except OSError:  # pragma: no cover - platforms without signal 0
        return True
    return True


def remove_stale_temporaries(
    folder: str | os.PathLike, legacy_names: Iterable[str] = ()
) -> list[Path]:
    """Remove the temporaries that killed writers left in ``folder``; return them.

    A temporary ``.NAME.PID.RANDOM.tmp`` (file or folder), or the ``.NAME.old-PID``
    of an interrupted :func:`atomic_dir` swap, is removed when process PID no longer
    runs. ``legacy_names`` are file names whose temporaries of earlier pdmkit versions
    (``.NAME.RANDOM.tmp``, no process id) are removed too (``"*"``: any name): pass
    them only while holding the folder's lock. Nothing else is touched.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> _ = (d / ".report.html.999999999.k2j4.tmp").write_text("half")
    >>> _ = (d / "notes.tmp").write_text("mine")
    >>> [p.name for p in remove_stale_temporaries(d)], sorted(p.name for p in d.iterdir())
    (['.report.html.999999999.k2j4.tmp'], ['notes.tmp'])
    """
    folder = Path(folder)
    legacy = [
        re.compile(rf"^\.{'.+' if n == '*' else re.escape(n)}\.[A-Za-z0-9_]{{6,12}}\.tmp$")
        for n in legacy_names
    ]
    removed = []
    try:
        entries = list(folder.iterdir())
    except (FileNotFoundError, NotADirectoryError):
        return removed
    for entry in entries:
        name = entry.name
        if not name.startswith("."):
            continue
        match = _TMP.match(name) or _OLD.match(name)
        stale = match is not None and not pid_alive(int(match["pid"]))
        if not stale and match is None:
            stale = any(p.match(name) for p in legacy)
        if not stale:
            continue
        if entry.is_dir() and not entry.is_symlink():
            shutil.rmtree(entry, ignore_errors=True)
        else:
            entry.unlink(missing_ok=True)
        removed.append(entry)
    return removed
