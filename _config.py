"""Where pdmkit looks for the shared recorded datasets."""

from __future__ import annotations

import os
from pathlib import Path

__all__ = ["data_dir", "max_bytes"]

_ENV = "PDMKIT_DATA"


def data_dir(*parts: str, must_exist: bool = False) -> Path:
    """Return the data directory, or a path below it.

    The directory is ``$PDMKIT_DATA`` when set, else ``../shared/data`` relative to the
    repository root (where the project's machines keep the recorded datasets).

    Parameters
    ----------
    *parts : str
        Path components below the data directory, e.g. ``"cwru_bearing"``.
    must_exist : bool, default False
        Raise :class:`pdmkit.errors.DataNotFoundError` when the path does not exist.

    Returns
    -------
    pathlib.Path

    Examples
    --------
    >>> from pdmkit import data_dir
    >>> data_dir("cwru_bearing").name
    'cwru_bearing'
    """
    env = os.environ.get(_ENV)
    if env:
        root = Path(env).expanduser()
        origin = f"${_ENV}={env}"
    else:
        # ../shared/data beside the checkout (editable install), else beside the
        # working directory (an installed wheel run from the checkout).
        candidates = [Path(__file__).resolve().parent.parent, Path.cwd().resolve().parent]
        root = next(
            (c / "shared" / "data" for c in candidates if (c / "shared" / "data").is_dir()),
            candidates[0] / "shared" / "data",
        )
        origin = f"the default ../shared/data (set ${_ENV} to use another place)"
    path = root.joinpath(*parts)
    if must_exist and not path.exists():
        from pdmkit.errors import DataNotFoundError

        raise DataNotFoundError(
            f"{path} does not exist; pdmkit looked in {origin}. Put the dataset folder "
            f"'{'/'.join(parts) or '.'}' there, or point {_ENV} at a directory that has it."
        )
    return path


#: Default ceilings on what pdmkit reads from untrusted files (bytes, decompressed).
#: Override with the environment variables named in :data:`_LIMIT_ENV`.
_LIMITS = {"member": 1 << 30, "model": 256 << 20}
_LIMIT_ENV = {"member": "PDMKIT_MAX_MEMBER_BYTES", "model": "PDMKIT_MAX_MODEL_BYTES"}


def max_bytes(kind: str) -> int:
    """Return the ceiling on the decompressed bytes pdmkit reads from one untrusted file.

    Files users hand to pdmkit (recordings, saved models) are checked against it
    *before* their arrays are read: the sizes their headers declare are compared first,
    so a small file that declares (or decompresses to) a huge array costs nothing.

    Parameters
    ----------
    kind : {"member", "model"}
        ``"member"``: one recording (one array of a ``.npz`` / ``.mat`` / Parquet
        member), default 1 GiB, ``$PDMKIT_MAX_MEMBER_BYTES``. ``"model"``: the whole
        content of a saved model file, default 256 MiB, ``$PDMKIT_MAX_MODEL_BYTES``.

    Returns
    -------
    int

    Examples
    --------
    >>> from pdmkit._config import max_bytes
    >>> max_bytes("model") >= 1 << 20
    True
    """
    if kind not in _LIMITS:
        raise ValueError(f"unknown limit {kind!r}; expected one of {sorted(_LIMITS)}")
    text = os.environ.get(_LIMIT_ENV[kind])
    if not text:
        return _LIMITS[kind]
    try:
        value = int(float(text))
    except ValueError:
        value = 0
    if value <= 0:
        from pdmkit.errors import DataError

        raise DataError(
            f"${_LIMIT_ENV[kind]}={text!r} is not a positive number of bytes; "
            f"unset it for the default {_LIMITS[kind]}"
        )
    return value
