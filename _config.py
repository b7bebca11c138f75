"""Where pdmkit looks for the shared recorded datasets."""

from __future__ import annotations

import os
from pathlib import Path

__all__ = ["data_dir"]

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
