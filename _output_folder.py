"""The checks an output folder passes before a command writes into it.

An output folder (``--out``) belongs to the user: :func:`check_output_folder` refuses,
before any work, a folder or ``--json`` path that would damage what is there (an input
overwritten, results written inside the input folder, a summary inside pdmkit's own
``.pdmkit`` folder). :data:`OUTPUTS` lists the files each command writes;
:mod:`pdmkit._outputs` writes them.
"""

from __future__ import annotations

import glob
import os
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from pdmkit.errors import DataError

__all__ = [
    "MAIN_JSON",
    "OUTPUTS",
    "PRIVATE",
    "check_output_folder",
    "local_paths",
    "real_path",
]

#: The files each command writes into its output folder (paths relative to it).
#: Nothing else in the folder is ever replaced or removed (``.pdmkit/`` and the
#: ``features`` partition store ``run/`` are pdmkit's own).
OUTPUTS: dict[str, tuple[str, ...]] = {
    "features": ("features.parquet", "errors.parquet", "report.html", "summary.json"),
    "rank": ("ranking.parquet", "report.html", "summary.json"),
    "classify": ("model.pdmkit", "report.html", "summary.json"),
    "predict": ("predictions.csv", "recordings.csv", "report.html", "summary.json"),
    "monitor": ("model.pdmkit", "report.html", "summary.json"),
    "monitor-score": ("report.html", "summary.json"),
    "sensors": ("report.html", "summary.json"),
    "rul": ("predictions.parquet", "model.pdmkit", "report.html", "summary.json"),
    "rul-trained": ("predictions.csv", "report.html", "summary.json"),
    "identify": ("report.html", "summary.json"),
    "mismatch": ("candidates.csv", "report.html", "summary.json"),
    "demo": (
        "features.parquet",
        "rul/predictions.parquet",
        "rul/model.pdmkit",
        "rul/report.html",
        "rul/summary.json",
        "report.html",
        "summary.json",
    ),
    "study": ("report.html", "summary.json"),
}

#: The JSON summary of each command: what ``--json PATH`` receives a copy of (every
#: command calls it ``summary.json``).
MAIN_JSON: dict[str, str] = dict.fromkeys(OUTPUTS, "summary.json")

#: pdmkit's own folder inside an output folder.
PRIVATE = ".pdmkit"


def real_path(path: str | os.PathLike) -> str:
    """The absolute path with every symbolic link resolved."""
    return os.path.realpath(os.path.abspath(os.fspath(path)))


def local_paths(inputs: Iterable[Any]) -> list[Path]:
    """The existing local files and folders among ``inputs`` (globs expanded)."""
    paths = []
    for item in inputs:
        if item is None or not isinstance(item, str | os.PathLike):
            continue
        text = os.fspath(item)
        if "://" in text:
            continue  # an fsspec URL: not on this file system
        if glob.has_magic(text) and not os.path.exists(text):
            paths += [Path(p) for p in glob.glob(text, recursive=True)]
        elif os.path.exists(text):
            paths.append(Path(text))
    return paths


def _same(a: Path, b: Path) -> bool:
    """Whether two paths name the same file."""
    try:
        return os.path.samefile(a, b)
    except OSError:
        return real_path(a) == real_path(b)


def _private_folder(path: Path, out: str | os.PathLike | None) -> Path | None:
    """The ``.pdmkit`` folder ``path`` lies in (``out``'s, or any other), or None."""
    real = Path(real_path(path))
    if out is not None:
        own = Path(real_path(Path(out) / PRIVATE))
        if real == own or own in real.parents:
            return Path(out) / PRIVATE
    for parent in (real, *real.parents):
        if parent.name == PRIVATE:
            return parent
    return None


def check_output_folder(
    out: str | os.PathLike | None,
    command: str,
    *,
    inputs: Iterable[Any] = (),
    json_path: str | os.PathLike | None = None,
) -> None:
    r"""Refuse, before any work, an output that would damage the user's files.

    Refused with a one-line :class:`~pdmkit.errors.DataError`: ``out`` is an existing
    file (or lies below one); one of the command's files (:data:`OUTPUTS`) exists there
    as a folder; one of them would overwrite a file the command reads (``inputs``), or
    land inside a folder it reads; ``json_path`` is a folder, is an input, or is one of
    the other files of the run, or lies in a ``.pdmkit`` folder (``out``'s own, where
    the lock, the staging folders and ``run.json`` live, or another output folder's).
    An input that merely sits in ``out`` under another name is fine.

    Parameters
    ----------
    out : path or None
        The output folder (None: only ``json_path`` is checked).
    command : str
        A key of :data:`OUTPUTS`.
    inputs : iterable of path
        Files and folders the command reads (globs are expanded; URLs and objects that
        are not paths are skipped).
    json_path : path, optional
        Where ``--json`` writes a copy of the summary.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> out = pathlib.Path(tempfile.mkdtemp())
    >>> _ = (out / "report.html").write_text("time,x\n0,1\n")
    >>> check_output_folder(out, "identify", inputs=[out / "report.html"])
    Traceback (most recent call last):
    ...
    pdmkit.errors.DataError: ... would overwrite the input ...report.html...
    >>> check_output_folder(out, "identify", inputs=[out / "data.csv"])  # fine
    """
    names = OUTPUTS[command]
    sources = local_paths(inputs)
    out = None if out is None else Path(out)
    if out is not None:
        _check_out(out, command, names, sources)
    if json_path is not None:
        _check_json_path(Path(json_path), out, command, names, sources)


def _check_out(out: Path, command: str, names: tuple, sources: list[Path]) -> None:
    """The output folder is a folder, and writing into it spares the inputs."""
    probe = out
    while not probe.exists() and probe != probe.parent:
        probe = probe.parent
    if probe.exists() and not probe.is_dir():
        what = "is an existing file" if probe == out else f"lies below the file {probe}"
        raise DataError(
            f"output folder {out} {what}, not a folder; name a folder for --out "
            f"(pdmkit writes {', '.join(names)} into it)"
        )
    for name in names:
        target = out / name
        if target.is_dir() and not target.is_symlink():
            raise DataError(
                f"output folder {out}: {target} is a folder, but {command} writes a "
                f"file of that name; rename the folder or choose another --out"
            )
        for src in sources:
            if src.is_file() and target.exists() and _same(target, src):
                raise DataError(
                    f"output folder {out}: writing {name} would overwrite the input "
                    f"{src}; choose another --out folder or move the input"
                )
    out_real = real_path(out)
    for src in sources:
        if src.is_dir():
            src_real = real_path(src).rstrip(os.sep)
            if out_real == src_real or out_real.startswith(src_real + os.sep):
                raise DataError(
                    f"output folder {out} is inside the input folder {src}: the "
                    f"results would become part of the input; choose an --out "
                    "outside it"
                )


def _check_json_path(
    js: Path, out: Path | None, command: str, names: tuple, sources: list[Path]
) -> None:
    """``--json`` names a file that is no input, no file of the run, not in .pdmkit."""
    if js.is_dir():
        raise DataError(
            f"--json {js} is a folder; name a file, e.g. {js / MAIN_JSON[command]}"
        )
    private = _private_folder(js, out)
    if private is not None:
        raise DataError(
            f"--json {js} is inside {private}, pdmkit's own folder (the output "
            "folder's lock, staging area and run manifest); name a file outside it, "
            f"e.g. {private.parent / MAIN_JSON[command]}"
        )
    for src in sources:
        if src.is_file() and js.exists() and _same(js, src):
            raise DataError(
                f"--json {js} is the input {src}; writing the summary there would "
                "overwrite it; name another file"
            )
    if out is not None:
        for name in names:
            if name != MAIN_JSON[command] and real_path(js) == real_path(out / name):
                raise DataError(
                    f"--json {js} is the {name} this run writes into {out}; name "
                    "another file"
                )
