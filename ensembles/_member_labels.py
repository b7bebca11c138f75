"""Conditions a member file gets from its name: a pattern's groups, a labels table's row.

Used by :func:`pdmkit.ensembles.read_members` (``label_from_name=``, ``labels=``).
"""

from __future__ import annotations

import re
import warnings
from pathlib import Path
from typing import Any

import pandas as pd

from pdmkit.ensembles._limits import _why
from pdmkit.ensembles._table_files import read_table
from pdmkit.errors import DataError, DataWarning, did_you_mean

__all__: list[str] = []


class _NameConditions:
    """Condition values a member gets from its file name.

    A regular expression's groups (``label_from_name``) and a labels table's row
    (``labels``).
    """

    _KEYS = ("file", "member", "name", "filename", "path")

    def __init__(self, label_from_name: Any, labels: Any) -> None:
        self.pattern = self._pattern(label_from_name)
        self.table, self.source = self._table(labels)
        self.used: set = set()

    @staticmethod
    def _pattern(regex: Any) -> re.Pattern | None:
        if regex is None:
            return None
        try:
            pattern = re.compile(regex)
        except (re.error, TypeError) as exc:
            raise DataError(
                f"label_from_name (--label-from-name) {regex!r} is not a regular "
                f"expression ({_why(exc)})"
            ) from None
        if not pattern.groupindex and pattern.groups != 1:
            raise DataError(
                f"label_from_name (--label-from-name) {pattern.pattern!r} has "
                f"{pattern.groups} groups; it needs one group (...) for the label, or "
                r"named groups (?P<label>...) (?P<load>\d+) for condition columns, "
                r"e.g. '^\d+_([A-Za-z]+)'"
            )
        return pattern

    def _table(self, labels: Any) -> tuple[dict | None, str]:
        if labels is None:
            return None, ""
        if isinstance(labels, pd.DataFrame):
            table, source = labels, "the labels table"
        else:
            table, source = read_table(labels), f"labels table {labels}"
        lower = {str(c).lower(): c for c in table.columns}
        key = next((lower[k] for k in self._KEYS if k in lower), None)
        if key is None:
            raise DataError(
                f"{source}: no column names the member files; expected one of "
                f"{list(self._KEYS)} (the file name, e.g. a.csv, or its member id a), "
                f"found {[str(c) for c in table.columns]}"
            )
        if table.shape[1] < 2:
            raise DataError(
                f"{source}: only the column {key!r}; add the label / condition columns "
                "beside it (e.g. file,fault)"
            )
        # keyed by member id: "a.csv" and "a" name the same member
        names = table[key].astype(str).map(lambda v: Path(v.strip()).name.split(".")[0])
        dup = names[names.duplicated()].unique().tolist()
        if dup:
            raise DataError(
                f"{source}: member file(s) {dup[:5]} are listed more than once; give "
                "each member one row"
            )
        rows = table.drop(columns=[key]).to_dict(orient="records")
        out = {}
        for name, row in zip(names, rows, strict=True):
            out[name] = {str(k): v for k, v in row.items()}
        return out, source

    def conditions(self, path: Path) -> dict:
        """The conditions ``path``'s name gives; DataError when it gives none."""
        extra: dict = {}
        if self.pattern is not None:
            match = self.pattern.search(path.name)
            if match is None:
                raise DataError(
                    f"{path.name}: its name does not match label_from_name "
                    f"(--label-from-name) {self.pattern.pattern!r}, so it has no label; "
                    "rename the file or widen the expression"
                )
            found = match.groupdict() if self.pattern.groupindex else {"label": match[1]}
            # a group that took no part in the match gives no value
            extra.update({k: v for k, v in found.items() if v is not None})
        if self.table is not None:
            key = stem = path.name.split(".")[0]
            if key not in self.table:
                raise DataError(
                    f"{path.name} is not listed in {self.source}; add a row for it "
                    f"(by file name {path.name!r} or member id {stem!r})"
                    f"{did_you_mean(path.name, self.table)}"
                )
            self.used.add(key)
            for name, value in self.table[key].items():
                if name in extra and str(extra[name]) != str(value):
                    raise DataError(
                        f"{path.name}: condition {name!r} is {extra[name]!r} by its name "
                        f"(label_from_name) but {value!r} in {self.source}; keep one"
                    )
                extra[name] = value
        return extra

    @staticmethod
    def merge(path: Path, conditions: dict, extra: dict) -> dict:
        """The file's own ``conditions`` and ``extra``; a clash is a DataError."""
        for name, value in extra.items():
            own = conditions.get(name)
            if own is not None and str(own) != str(value):
                raise DataError(
                    f"{path.name}: condition {name!r} is {own!r} in the file but "
                    f"{value!r} from its name or the labels table; keep one"
                )
        return {**conditions, **extra}

    def warn_unused(self) -> None:
        """A DataWarning for labels-table rows that name no member file read."""
        if self.table is None:
            return
        unused = [k for k in self.table if k not in self.used]
        if unused:
            warnings.warn(
                f"{self.source}: {len(unused)} row(s) name no member file read: "
                f"{unused[:5]}{' ...' if len(unused) > 5 else ''}; check the names",
                DataWarning,
                stacklevel=3,
            )
