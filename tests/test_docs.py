"""The README and the guides in docs/ keep the shape that makes them teach.

* README.md fits in 150 lines and explains "the source thesis" once, in one defined
  phrase, then uses that name (never "the seed", the code's name for it);
* a guide (docs/*.md; measurement logs live in docs/results/) has no heading that dates
  it or tells its history ("(2026-11-24)", "(latest)", "(issue 15)") and opens with a
  how-to: a code block within its first screen;
* no page shows code that imports a private module (``from pdmkit.x._y import``), and
  every name a code block imports from pdmkit is in that module's ``__all__``;
* every relative link in README.md and docs/**/*.md points at a file (and heading) that
  exists.

Everything is read as text (``__all__`` with ``ast``): nothing heavy is imported.
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
DOCS = ROOT / "docs"
RESULTS = DOCS / "results"
#: Pages for contributors and the list of sources: reference, not task guides.
NOT_GUIDES = {"ARCHITECTURE.md", "CONVENTIONS.md", "REFERENCES.md"}
#: The one sentence that says what "the source thesis" is (README.md).
DEFINITION = "**the source thesis**"
ONE_SCREEN = 40  # lines

MONTHS = "Jan|Feb|Mar|Apr|May|Jun|Jul|Aug|Sep|Oct|Nov|Dec"
HISTORY_HEADING = re.compile(
    rf"\b\d{{4}}-\d{{2}}-\d{{2}}\b"  # 2026-11-24
    rf"|\b\d{{1,2}} (?:{MONTHS})[a-z]* \d{{4}}\b"  # 24 Nov 2026
    rf"|\b(?:{MONTHS})[a-z]* \d{{4}}\b"  # November 2026
    r"|\((?:[^)]*[\s,;])?(?:latest|earlier|later)\)"  # (24 Nov 2026, latest), (later)
    r"|\bissue \d+\b",  # (issue 15), (issue 3, done-when)
    flags=re.I,
)
PRIVATE_IMPORT = re.compile(
    r"\bfrom\s+pdmkit(?:\.\w+)*\._\w+(?:\.\w+)*\s+import\b"
    r"|\bimport\s+pdmkit(?:\.\w+)*\._\w+"
)
PUBLIC_IMPORT = re.compile(
    r"^[ \t]*from\s+(pdmkit(?:\.\w+)*)\s+import\s+(\([^)]*\)|[^\n]+)", re.M
)
LINK = re.compile(r"!?\[[^\]]*\]\(([^)\s]+)\)")


def _pages() -> list[Path]:
    return [README, *sorted(DOCS.rglob("*.md"))]


def _guides() -> list[Path]:
    return [p for p in sorted(DOCS.glob("*.md")) if p.name not in NOT_GUIDES]


def _prose(text: str) -> list[tuple[int, str]]:
    """(line number, line) of the lines outside fenced code blocks."""
    out, fenced = [], False
    for number, line in enumerate(text.splitlines(), 1):
        if line.lstrip().startswith("```"):
            fenced = not fenced
        elif not fenced:
            out.append((number, line))
    return out


def _code_blocks(text: str) -> list[str]:
    return re.findall(r"^[ \t]*```[\w-]*\n(.*?)^[ \t]*```", text, flags=re.S | re.M)


def _slug(heading: str) -> str:
    """GitHub's anchor of a heading: lower case, punctuation dropped, spaces to '-'."""
    text = re.sub(r"[`*_]", "", heading.strip().lstrip("#").strip().lower())
    return re.sub(r"[^\w\- ]", "", text).replace(" ", "-")


def _public_names(module: str) -> set[str] | None:
    """The literal ``__all__`` of a pdmkit module, read from its source."""
    parts = module.split(".")[1:]
    base = ROOT.joinpath(*parts)
    for path in (base / "__init__.py", base.with_suffix(".py")):
        if path.is_file():
            for node in ast.parse(path.read_text()).body:
                targets = getattr(node, "targets", None) or [getattr(node, "target", None)]
                if any(isinstance(t, ast.Name) and t.id == "__all__" for t in targets):
                    return set(ast.literal_eval(node.value))
            return set()
    return None


def test_readme_fits_in_150_lines():
    n_lines = len(README.read_text().splitlines())
    assert n_lines <= 150, f"README.md has {n_lines} lines; keep it at 150 or fewer"


def test_readme_defines_the_source_thesis_once_and_uses_that_name():
    text = README.read_text()
    prose = "\n".join(line for _, line in _prose(text))
    assert text.count(DEFINITION) == 1, f"README.md must define {DEFINITION} exactly once"
    definition = next(line for line in text.splitlines() if DEFINITION in line)
    paragraph = text[text.index(definition) :].split("\n\n")[0]
    assert "Voronin" in paragraph and "pneumatic pistons" in paragraph, paragraph
    assert text.count("Voronin") == 1, (
        "README.md names the thesis's author once, in its definition"
    )
    assert prose.count("the source thesis") >= 3, (
        "use the defined name where the thesis is meant"
    )
    seed = [line for line in prose.splitlines() if re.search(r"\bthe seed\b", line)]
    seed = [line for line in seed if "calls it" not in line]  # the definition says so
    assert not seed, f"README.md calls the thesis 'the seed': {seed}"


@pytest.mark.parametrize("page", sorted(DOCS.glob("*.md")), ids=lambda p: p.name)
def test_guide_headings_carry_no_dates_or_history(page):
    bad = [
        f"{page.name}:{number}: {line.strip()}"
        for number, line in _prose(page.read_text())
        if line.startswith("#") and HISTORY_HEADING.search(line)
    ]
    assert not bad, "move dated or historical sections to docs/results/: " + "; ".join(bad)


@pytest.mark.parametrize("page", _guides(), ids=lambda p: p.name)
def test_guide_opens_with_a_how_to(page):
    lines = page.read_text().splitlines()
    first = next(
        (i for i, line in enumerate(lines, 1) if line.lstrip().startswith("```")), None
    )
    assert first is not None and first <= ONE_SCREEN, (
        f"{page.name}: open with the commands or code of the common case "
        f"(first code block at line {first}, want <= {ONE_SCREEN})"
    )


def test_history_heading_pattern_catches_what_it_should():
    # the rule itself, against an independent list of headings
    caught = [
        "### Cascaded Tanks (24 Nov 2026, latest)",
        "## Measured (2026-11-29)",
        "## RUL in your units (issue 15)",
        "### After the pooled test (later)",
        "# Fault classification (issue 3, done-when)",
    ]
    passed = [
        "## Results (full run, random seed 0)",
        "## What was changed (after)",
        "## Tests",
    ]
    assert all(HISTORY_HEADING.search(h) for h in caught)
    assert not any(HISTORY_HEADING.search(h) for h in passed)


@pytest.mark.parametrize("page", _pages(), ids=lambda p: str(p.relative_to(ROOT)))
def test_no_private_module_imported_in_docs(page):
    bad = PRIVATE_IMPORT.findall(page.read_text())
    assert not bad, (
        f"{page.relative_to(ROOT)} imports a private module: {bad}; use the public path"
    )


def test_private_import_pattern():
    assert PRIVATE_IMPORT.search("from pdmkit.ensembles._distributed import dask_map")
    assert PRIVATE_IMPORT.search("from pdmkit._persist import save_model")
    assert PRIVATE_IMPORT.search("import pdmkit.models.ident._model as m")
    assert not PRIVATE_IMPORT.search("from pdmkit.ensembles import dask_map")
    assert not PRIVATE_IMPORT.search("from pdmkit import load_model")


def _imported(names: str) -> list[str]:
    """The names of ``a, b as c`` or ``(a, b)`` (comments dropped)."""
    names = re.sub(r"#[^\n]*", "", names).strip("() \n")
    return [item.split()[0] for item in names.split(",") if item.strip()]


@pytest.mark.parametrize("page", _pages(), ids=lambda p: str(p.relative_to(ROOT)))
def test_code_imports_only_public_names(page):
    bad = []
    for block in _code_blocks(page.read_text()):
        for module, names in PUBLIC_IMPORT.findall(block):
            public = _public_names(module)
            if public is None:
                bad.append(f"{module} (no such module)")
                continue
            bad += [f"{module}.{name}" for name in _imported(names) if name not in public]
    assert not bad, f"{page.relative_to(ROOT)} imports names that are not public: {bad}"


def test_imported_names_are_read_as_written():
    assert _imported("(\n    dask_map,\n    simulate_sweep,  # one task each\n)") == [
        "dask_map",
        "simulate_sweep",
    ]
    assert _imported("load_model, save_model as save") == ["load_model", "save_model"]
    assert _public_names("pdmkit.rul") >= {"HealthIndicator", "rmse"}
    assert _public_names("pdmkit.no_such_module") is None


@pytest.mark.parametrize("page", _pages(), ids=lambda p: str(p.relative_to(ROOT)))
def test_relative_links_point_at_files_that_exist(page):
    text = "\n".join(line for _, line in _prose(page.read_text()))
    text = re.sub(r"`[^`\n]*`", "", text)  # a link inside inline code is not a link
    bad = []
    for target in LINK.findall(text):
        if re.match(r"[a-z][a-z0-9+.-]*:", target):  # http:, https:, mailto:
            continue
        path, _, anchor = target.partition("#")
        file = (page.parent / path).resolve() if path else page
        if not file.exists():
            bad.append(f"{target} (no such file)")
        elif anchor and file.suffix == ".md":
            headings = [
                line for _, line in _prose(file.read_text()) if line.startswith("#")
            ]
            if anchor not in {_slug(h) for h in headings}:
                bad.append(f"{target} (no such heading)")
    assert not bad, f"{page.relative_to(ROOT)}: broken links {bad}"
