"""How workflows speak and finish: one line on stderr, and the run's two files.

On the command line pdmkit speaks command line: :func:`say` prints ``pdmkit: ...``
lines (nothing under ``--quiet``), :func:`say_error` the one error line, and
:func:`cli_warnings` turns Python warnings into ``pdmkit: warning: ...`` lines, each
distinct warning once, its repeats counted. :func:`cli_text` rewrites the advice that
messages give Python callers (``pass fs=``) into the flags a command-line user types
(``--fs``); library callers keep the Python names.
"""

from __future__ import annotations

import contextlib
import logging
import re
import sys
import warnings
from collections.abc import Iterator
from pathlib import PurePath

from pdmkit._outputs import OutputRun
from pdmkit._progress import is_silenced

__all__ = ["cli_text", "cli_warnings", "finish", "say", "say_error"]


def say(message: str, *, always: bool = False) -> None:
    """Print ``pdmkit: message`` on stderr (progress and results people read).

    Nothing under ``--quiet`` (:func:`pdmkit._progress.silenced`) unless ``always``: a
    line the user must read even then (members left out, ...).

    Examples
    --------
    >>> say("hello")  # on stderr
    """
    if always or not is_silenced():
        print(f"pdmkit: {cli_text(message)}", file=sys.stderr, flush=True)


def say_error(message: object) -> None:
    """Print ``pdmkit: error: message`` on stderr, on one line, as the last line.

    The repeats of warnings still untold (:func:`cli_warnings`) are told first, so the
    error closes the command's output.

    Examples
    --------
    >>> say_error("no such file: a.csv")  # on stderr
    """
    for told in _OPEN:
        told.tell_repeats()
    say("error: " + _one_line(str(message)), always=True)


def finish(run: OutputRun, summary: dict, report, then=None) -> None:
    """Register ``summary.json`` and ``report.html`` with the run and commit it."""
    run.add_json("summary.json", summary)
    run.add_report("report.html", report)
    run.commit(then)
    say(f"wrote {run.path('summary.json')} and {run.path('report.html')}")


def _one_line(text: str) -> str:
    return " ".join(part.strip() for part in text.splitlines() if part.strip())


# ----------------------------------------------------------- advice in flag names
#: Python keywords whose flag means the same in every command that can meet the
#: message: ``test_size=0.5`` reads ``--test-size 0.5``, ``lower test_size`` reads
#: ``lower --test-size``. The RUL models' options are ``pdmkit rul --option NAME=VALUE``.
_FLAGS = {
    "test_size": "--test-size",
    "split": "--split",
    "unit": "--unit",
    "time": "--time",
    "workers": "--workers",
    **{
        name: f"--option {name}="
        for name in (
            "threshold",
            "noise_var",
            "diffusion_var",
            "measurement_var",
            "prior",
            "offset",
            "shape",
            "pad",
        )
    },
}

#: Advice a message carries for both: a keyword in Python syntax, or spelled as its
#: flag, then the flag (``pass fs= (--fs)``, ``resample=HZ (--resample HZ)``,
#: ``label_from_name (--label-from-name)``): the command line keeps the flag.
_BOTH = re.compile(
    r"\b(?:(?P<verb>pass|give|set|use) )?(?P<kw>[a-z_][a-z0-9_]*)(?P<eq>=[^\s()]*)? "
    r"\((?P<flag>--(?P<name>[a-z][a-z0-9-]*)(?: [A-Z][A-Z_]*)?)\)"
)


def _keep_flag(match: re.Match) -> str:
    if not match["eq"] and match["kw"].replace("_", "-") != match["name"]:
        return match[0]  # "the labels table (--labels)": not a keyword
    return ("give " if match["verb"] else "") + match["flag"]


#: ``test_size=0.25``, ``split='group'``, ``unit=<column ...>``, ``prior={...}``; bare
#: names with an underscore (``lower test_size``), never a plain word (``unit``).
_KEYWORD = re.compile(
    r"(?<![/\\.-])\b(?:(?P<verb>pass|give|set|use) )?(?P<kw>" + "|".join(_FLAGS) + ")"
    r"(?P<eq>=(?:'(?P<quoted>[^']*)'|(?P<value>\{.*\}|<[^>]*>|[^\s,;)]*)))?"
    r"(?![A-Za-z0-9_])"
)

#: Advice only a Python caller can follow (no flag does it): the command line leaves
#: it out, and what is left still says what to do (add a header line, ...).
_PYTHON_ONLY = re.compile(
    r",? or pass names=\[\.\.\.\] to read_table(?: \(header=0 if that line is a "
    r"header\))?|,? or pass na_values=\[.*?\] if it marks one|,? or pass dtype=\{.*?\} "
    r"to read them all as text"
)

#: Advice whose flag differs by name from the keyword (in the commands it reaches),
#: and ``(time= / --time)``.
_RENAMED = (
    (re.compile(r"rows with time=(?=$|[\s.;,)])"), "rows with --order"),
    (re.compile(r"\([a-z_][a-z0-9_]*= / (--[a-z][a-z0-9-]*)\)"), r"(\1)"),
)


def cli_text(text: str) -> str:
    """``text`` with the advice it gives Python callers in command-line flags.

    Messages name keyword arguments for library callers (``pass fs=``); at the command
    line the same advice names the flags (``--fs``). What is rewritten is listed here
    and nowhere else: advice that carries both (``pass fs= (--fs)``) keeps the flag; a
    keyword with the same flag wherever the message can come from (``test_size=0.5`` →
    ``--test-size 0.5``, a RUL model's ``noise_var=`` → ``--option noise_var=VALUE``)
    is renamed, as are the few whose flag has another name (``time=`` ordering rank's
    rows → ``--order``); advice only Python can follow (``names=[...] to
    read_table``) is left out. A message's own values (paths, quoted names) are kept.

    Examples
    --------
    >>> cli_text("no time column; drop it and pass fs= (--fs)")
    'no time column; drop it and give --fs'
    >>> cli_text("split='group' needs groups; lower test_size, e.g. test_size=0.2")
    '--split group needs groups; lower --test-size, e.g. --test-size 0.2'
    >>> cli_text("Add a header line to the file, or pass names=[...] to read_table")
    'Add a header line to the file'
    """
    text = _BOTH.sub(_keep_flag, text)
    text = _PYTHON_ONLY.sub("", text)
    for pattern, flag in _RENAMED:
        text = pattern.sub(flag, text)
    return _KEYWORD.sub(_flag_of, text)


def _flag_of(match: re.Match) -> str:
    flag = _FLAGS[match["kw"]]
    option = flag.endswith("=")  # --option NAME=VALUE
    if match["eq"] is None and (option or "_" not in match["kw"]):
        return match[0]  # a plain word, or an option's name in a sentence
    value = match["quoted"] if match["quoted"] is not None else match["value"]
    if option:
        value = value or "VALUE"
        if value.startswith("{"):  # JSON, as --option reads it
            value = "'" + value.replace("'", '"') + "'"
    verb = "give " if match["verb"] else ""
    return f"{verb}{flag}{value}" if option else f"{verb}{flag} {value or ''}".rstrip()


# ------------------------------------------------------------ warnings as lines
#: What varies between repeats of one warning: a quoted value, a path or file name,
#: a number.
_VARYING = re.compile(
    r"'[^']*'|\"[^\"]*\"|(?:[\w.~-]*[/\\])+[\w.-]+|\b[\w-]+\.[A-Za-z]\w{0,4}\b"
    r"|[-+]?\d+(?:\.\d+)?(?:[eE][-+]?\d+)?"
)


class _Warned:
    """One distinct warning: its first text, how often it came again, and with what."""

    def __init__(self, text: str) -> None:
        self.text, self.again, self.told = text, 0, 0
        self.parts = _VARYING.findall(text)
        self.others: list[str] = []

    def repeat(self, text: str) -> None:
        self.again += 1
        parts = _VARYING.findall(text)
        other = next((b for a, b in zip(self.parts, parts, strict=False) if a != b), None)
        if other is not None and other not in self.others and len(self.others) < 4:
            self.others.append(other)

    def summary(self) -> str:
        """``(59 more times, for b.csv, c.csv, d.csv, ...) <the first, shortened>``."""
        n = self.again - self.told
        shown = [_short(o) for o in self.others[:3]]
        where = ", for " + ", ".join(shown) if shown else ""
        more = ", ..." if shown and (len(self.others) > 3 or n > len(shown)) else ""
        head = _VARYING.sub(lambda m: _short(m[0]), self.text)
        head = head if len(head) <= 100 else head[:97].rsplit(" ", 1)[0] + " ..."
        return f"({n} more time{'s' * (n != 1)}{where}{more}) {head}"


def _short(token: str) -> str:
    """A path as its file name (the rest is in the first line shown)."""
    if "/" in token or "\\" in token:
        return PurePath(token.strip("'\"")).name or token
    return token


class _WarningLines:
    """The warnings of one command: each distinct one printed once, repeats counted."""

    def __init__(self, stream) -> None:
        self.stream = stream
        self.seen: dict[tuple, _Warned] = {}

    def show(self, message, category, filename, lineno, file=None, line=None) -> None:
        """A ``warnings.showwarning``: one ``pdmkit: warning:`` line, or a count."""
        self.add(str(message), category)

    def add(self, message: str, kind) -> None:
        """Print ``message`` (of ``kind``: its category or logger) or count it."""
        text = cli_text(_one_line(message)) or getattr(kind, "__name__", str(kind))
        key = (kind, _VARYING.sub("\0", text))
        if key in self.seen:
            self.seen[key].repeat(text)
            return
        self.seen[key] = _Warned(text)
        self._print(text)

    def tell_repeats(self) -> None:
        """One line per warning that came again since the last time they were told."""
        for warned in self.seen.values():
            if warned.again > warned.told:
                self._print(warned.summary())
                warned.told = warned.again

    def _print(self, text: str) -> None:
        stream = self.stream if self.stream is not None else sys.stderr
        print(f"pdmkit: warning: {text}", file=stream, flush=True)


class _LogLines(logging.Handler):
    """Log records of warning level and above as ``pdmkit: warning:`` lines too."""

    def __init__(self, lines: _WarningLines) -> None:
        super().__init__(logging.WARNING)
        self.lines = lines

    def emit(self, record: logging.LogRecord) -> None:
        try:
            self.lines.add(record.getMessage(), record.name)
        except Exception:  # logging's own rule: a record never raises
            self.handleError(record)


#: The :func:`cli_warnings` blocks open now (innermost last).
_OPEN: list[_WarningLines] = []


@contextlib.contextmanager
def cli_warnings(stream=None) -> Iterator[None]:
    """Inside the block, Python warnings are ``pdmkit: warning: <message>`` lines.

    No file, line of source or category: the message on one line, with its advice in
    flags (:func:`cli_text`). Each distinct warning is printed once, when it first
    comes; its repeats (the same text, or the same text about another file or value)
    are counted, and told at the end of the block in one line each,
    ``pdmkit: warning: (59 more times, for b.csv, c.csv, d.csv, ...) <the warning>``
    (or before the error line, :func:`say_error`). The warning filters in force still
    decide which warnings count (ignored ones stay ignored; those shown once per place
    are all counted). Records of warning level and above that libraries log (and that
    reach the root logger) become such lines too. Lines go to ``stream`` (default:
    stderr at the time). Warnings raised in worker processes are not seen. The console
    command ``pdmkit`` runs in this block; library calls keep Python's warnings.

    Examples
    --------
    >>> import sys, warnings
    >>> with cli_warnings(sys.stdout):
    ...     for name in ("a.csv", "b.csv", "c.csv"):
    ...         warnings.warn(f"{name}: no header line", UserWarning, stacklevel=1)
    pdmkit: warning: a.csv: no header line
    pdmkit: warning: (2 more times, for b.csv, c.csv) a.csv: no header line
    """
    lines = _WarningLines(stream)
    handler, root = _LogLines(lines), logging.getLogger()
    with warnings.catch_warnings():  # puts showwarning and the filters back after
        warnings.filters[:] = [  # every occurrence reaches the count
            ("always", *f[1:]) if f[0] in ("default", "module", "once") else f
            for f in warnings.filters
        ]
        warnings.simplefilter("always", append=True)
        warnings.showwarning = lines.show
        root.addHandler(handler)
        _OPEN.append(lines)
        try:
            yield
        finally:
            _OPEN.remove(lines)
            root.removeHandler(handler)
            lines.tell_repeats()
