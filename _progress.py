"""Progress bars that show on a terminal and stay quiet otherwise."""

from __future__ import annotations

import sys
from collections.abc import Iterable, Iterator
from typing import TypeVar

T = TypeVar("T")

__all__ = ["progress", "progress_bar"]


def progress_bar(total: int, *, desc: str = "", enable: bool | None = None):
    """A tqdm bar of ``total`` steps when stderr is a terminal (``enable``), else None.

    Examples
    --------
    >>> progress_bar(3, desc="stages", enable=False) is None
    True
    """
    if enable is None:
        enable = sys.stderr.isatty()
    if not enable:
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

    Examples
    --------
    >>> list(progress(range(3), desc="members", enable=False))
    [0, 1, 2]
    """
    if enable is None:
        enable = sys.stderr.isatty()
    if not enable:
        yield from iterable
        return
    from tqdm.auto import tqdm

    yield from tqdm(iterable, desc=desc, total=total, leave=False)
