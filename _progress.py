"""Progress bars that show on a terminal and stay quiet otherwise (or when silenced)."""

from __future__ import annotations

import contextlib
import sys
from collections.abc import Iterable, Iterator
from typing import TypeVar

T = TypeVar("T")

__all__ = ["is_silenced", "progress", "progress_bar", "silenced"]

#: How many :func:`silenced` blocks are open (``pdmkit ... --quiet`` opens one).
_SILENCED = [0]


@contextlib.contextmanager
def silenced(on: bool = True) -> Iterator[None]:
    """Inside the block (when ``on``), no progress bar shows and ``say`` says nothing.

    What ``--quiet`` means on the command line: bars stay off even where a caller
    forces them on (``enable=True``); warnings and errors are not affected.

    Examples
    --------
    >>> with silenced():
    ...     is_silenced()
    True
    >>> is_silenced()
    False
    """
    _SILENCED[0] += bool(on)
    try:
        yield
    finally:
        _SILENCED[0] -= bool(on)


def is_silenced() -> bool:
    """Whether a :func:`silenced` block is open.

    Examples
    --------
    >>> is_silenced()
    False
    """
    return _SILENCED[0] > 0


def _shown(enable: bool | None) -> bool:
    """Whether a bar shows: never when silenced, else ``enable`` or a terminal."""
    if is_silenced():
        return False
    return sys.stderr.isatty() if enable is None else bool(enable)


def progress_bar(total: int, *, desc: str = "", enable: bool | None = None):
    """A tqdm bar of ``total`` steps when stderr is a terminal (``enable``), else None.

    Examples
    --------
    >>> progress_bar(3, desc="stages", enable=False) is None
    True
    """
    if not _shown(enable):
        return None
    from tqdm.auto import tqdm

    return tqdm(total=total, desc=desc, leave=False)


def progress(
    iterable: Iterable[T],
    *,
    desc: str = "",
    total: int | None = None,
    enable: bool | None = None,
) -> Iterator[T]:
    """Wrap ``iterable`` in a tqdm bar when stderr is a terminal.

    Parameters
    ----------
    iterable : iterable
        What to iterate over.
    desc : str
        Label shown before the bar.
    total : int, optional
        Number of items, when ``len(iterable)`` is not available.
    enable : bool, optional
        Force the bar on (True) or off (False); default: on only for a terminal.
        Never on inside :func:`silenced` (``--quiet``).

    Examples
    --------
    >>> list(progress(range(3), desc="members", enable=False))
    [0, 1, 2]
    """
    if not _shown(enable):
        yield from iterable
        return
    from tqdm.auto import tqdm

    yield from tqdm(iterable, desc=desc, total=total, leave=False)
