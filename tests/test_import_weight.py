"""What importing pdmkit and each layer pulls in (issue 15, "answers in a second").

Each import runs in a fresh interpreter under ``python -X importtime``, which lists
every module imported with its cumulative time. The assertions are on the module sets
(what the design allows each layer to import), never on wall time; the measured
microseconds appear in a failure's message to show what the forbidden import cost.
"""

from __future__ import annotations

import subprocess
import sys

import pytest

#: Third-party packages that cost a second or more to import, or start machinery.
HEAVY = ("sklearn", "scipy", "pandas", "pyarrow", "torch", "matplotlib", "tqdm", "dask")
LAYERS = ("models", "ensembles", "features", "rul", "experiments")


def _above(layer: str) -> tuple[str, ...]:
    """The layers an import of ``layer`` must not reach (imports point down only)."""
    return tuple(f"pdmkit.{name}" for name in LAYERS[LAYERS.index(layer) + 1 :])


#: module -> what importing it must not import. ``pdmkit`` itself stays light (its
#: layers are attributes imported on first use); ensembles read data with numpy,
#: pandas and pyarrow only; no layer imports torch, matplotlib, tqdm or Dask until a
#: neural model, a figure, a progress bar on a terminal or a cluster is asked for.
CASES = {
    "pdmkit": (*HEAVY, *(f"pdmkit.{name}" for name in LAYERS)),
    "pdmkit.errors": (*HEAVY, *(f"pdmkit.{name}" for name in LAYERS)),
    "pdmkit._progress": HEAVY,
    "pdmkit.ensembles": (
        "sklearn",
        "scipy",
        "torch",
        "matplotlib",
        "tqdm",
        "dask",
        "distributed",
        *_above("ensembles"),
        "pdmkit.models",
    ),
    "pdmkit.models": ("torch", "matplotlib", "tqdm", "dask", *_above("models")),
    "pdmkit.features": ("torch", "matplotlib", "tqdm", "dask", *_above("features")),
    "pdmkit.rul": ("torch", "matplotlib", "tqdm", "dask", *_above("rul")),
    "pdmkit.experiments._cli": (
        "torch",
        "matplotlib",
        "tqdm",
        "dask",
        "distributed",
        "sklearn",
        "scipy",
        "pdmkit.models",
    ),
}


def _imported(module: str) -> dict[str, int]:
    """Every module ``import module`` loads in a fresh interpreter -> cumulative us."""
    done = subprocess.run(
        [sys.executable, "-X", "importtime", "-c", f"import {module}"],
        capture_output=True,
        text=True,
        check=True,
        timeout=120,
    )
    out: dict[str, int] = {}
    for line in done.stderr.splitlines():
        if not line.startswith("import time:") or "cumulative" in line:
            continue
        _, cumulative, name = line[len("import time:") :].split("|")
        out[name.strip()] = int(cumulative)
    return out


@pytest.mark.parametrize("module", sorted(CASES))
def test_import_pulls_in_only_what_its_layer_needs(module: str) -> None:
    imported = _imported(module)
    assert module in imported  # the measurement saw the import itself
    bad = {
        name: us
        for name, us in imported.items()
        if any(name == f or name.startswith(f + ".") for f in CASES[module])
    }
    tops = sorted({name.split(".")[0] for name in bad} | {n for n in bad if "pdmkit" in n})
    assert not bad, (
        f"import {module} ({imported[module] / 1e3:.0f} ms) also imports {tops}: "
        + ", ".join(f"{n} {us / 1e3:.0f} ms" for n, us in bad.items() if "." not in n)
    )


def test_version_and_help_answer_without_torch_or_plots() -> None:
    """``pdmkit --help`` builds the whole parser: still no torch, matplotlib, tqdm,
    scikit-learn, scipy or pdmkit's models (they made it take 1.2 s)."""
    code = (
        "import sys, contextlib, io\n"
        "from pdmkit._entry import main\n"
        "with contextlib.redirect_stdout(io.StringIO()) as out:\n"
        "    try:\n"
        "        main(['--help'])\n"
        "    except SystemExit as stop:\n"
        "        assert stop.code == 0\n"
        "assert 'rank' in out.getvalue()\n"
        "print(sorted(m for m in ('torch', 'matplotlib', 'tqdm', 'dask', 'sklearn', "
        "'scipy', 'pdmkit.models') if m in sys.modules))\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=120
    )
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.strip() == "[]"


def test_features_import_without_sklearn_or_the_models_layer() -> None:
    """The layer's names load on first use (a ranking pulls scikit-learn, a model-based
    group pulls pdmkit.models); importing the layer does neither."""
    imported = _imported("pdmkit.features")
    assert not {"sklearn", "pdmkit.models"} & set(imported)


def test_the_help_lists_every_identify_structure() -> None:
    """``--structure``'s choices are written out for a light ``--help``; they must be
    the structures ``run_identify`` knows."""
    from pdmkit.experiments._cli_models import IDENTIFY_CHOICES
    from pdmkit.experiments._identify import IDENTIFY_STRUCTURES

    assert list(IDENTIFY_CHOICES) == list(IDENTIFY_STRUCTURES)
