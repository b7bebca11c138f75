"""The designer's work on the server: one session, its steps and their results.

Each step calls the public pdmkit function the command line calls
(:func:`pdmkit.features.extract_ensemble`, :func:`pdmkit.features.rank_features`,
:func:`pdmkit.experiments.classify`, :func:`pdmkit.experiments.compare_sensors`), so the
exported command line and script reproduce its table and model. Long steps run as a
:class:`Job` in a thread; the page polls its progress.
"""

from __future__ import annotations

import math
import threading
import time
import uuid
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd

from pdmkit.errors import DataError, ModelError
from pdmkit.experiments.designer._project import (
    CLASS_RANKINGS,
    check_indicators,
    check_rank,
    check_sensors,
    check_train,
    parse_options,
)
from pdmkit.experiments.designer._views import filter_members

__all__ = ["Job", "Session", "extraction_options", "one_line"]


def one_line(exc: BaseException) -> str:
    r"""An error as the one line the page shows.

    Examples
    --------
    >>> one_line(ValueError("top_k must be\n a positive integer"))
    'top_k must be a positive integer'
    """
    text = " ".join(part.strip() for part in str(exc).splitlines() if part.strip())
    return text or type(exc).__name__


@dataclass
class Job:
    """A step running in a thread: its progress and, when done, its result or error.

    Examples
    --------
    >>> job = Job("features")
    >>> job.step(1, 4, "batch 1 of 4"); job.status()["fraction"]
    0.25
    """

    kind: str
    id: str = field(default_factory=lambda: uuid.uuid4().hex[:12])
    state: str = "running"
    done: int = 0
    total: int = 0
    message: str = ""
    error: str | None = None
    result: Any = None
    started: float = field(default_factory=time.perf_counter)
    seconds: float = math.nan

    def step(self, done: int, total: int, message: str = "") -> None:
        """Record progress."""
        self.done, self.total, self.message = done, total, message

    def status(self) -> dict:
        """What the page shows of the job."""
        fraction = self.done / self.total if self.total else None
        return {
            "id": self.id,
            "kind": self.kind,
            "state": self.state,
            "done": self.done,
            "total": self.total,
            "fraction": fraction,
            "message": self.message,
            "error": self.error,
            "seconds": None if math.isnan(self.seconds) else round(self.seconds, 3),
        }


def extraction_options(text: str) -> dict[str, Any]:
    """Options for :func:`~pdmkit.features.extract_ensemble` from the page's text.

    ``bearing`` is parsed into a :class:`pdmkit.features.BearingGeometry`.

    Examples
    --------
    >>> extraction_options("bearing=6205 shaft_hz=29.95")["bearing"].n_balls
    9
    """
    options = parse_options(text)
    if "bearing" in options and options["bearing"] is not None:
        from pdmkit.features import BearingGeometry

        options["bearing"] = BearingGeometry.parse(str(options["bearing"]))
    return options


def _counted(batches, job: Job, total: int, n_members: int):
    """Pass the batches through, reporting each one to the job."""
    done = 0
    for i, batch in enumerate(batches, start=1):
        yield batch
        done += len(batch)
        job.step(i, total, f"{done} of {n_members} members")


class Session:
    """One designer session: the source and the results of each step.

    Parameters
    ----------
    source : Source
        The members (see :func:`open_source`).

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.ensembles import Ensemble
    >>> from pdmkit.experiments.designer._source import Source
    >>> rng = np.random.default_rng(0)
    >>> x = rng.normal(size=(40, 1024)) * np.repeat([1.0, 3.0], 20)[:, None]
    >>> ens = Ensemble({"vib": x}, fs=1e3, conditions={"fault": ["a"] * 20 + ["b"] * 20})
    >>> s = Session(Source.from_ensemble(ens))
    >>> s.run_now("features", {"signals": ["vib"], "groups": ["stats"]})["n_features"]
    11
    >>> s.run_now("rank", {"method": "kruskal"})["ranking"][0]["feature"]
    'vib/stats/Std'
    >>> s.run_now("train", {"model": "knn", "top_k": 2})["accuracy"]
    1.0
    """

    def __init__(self, source) -> None:
        self.source = source
        self.label: str | None = source.label
        self.data: dict = {"filter": {}, "by": source.label, "signal": None}
        self.settings: dict[str, dict | None] = {
            "indicators": None,
            "rank": None,
            "train": None,
            "sensors": None,
        }
        self.table: pd.DataFrame | None = None
        self.ranking: pd.DataFrame | None = None
        self.result: Any = None
        self.sensors: Any = None
        self.jobs: dict[str, Job] = {}
        self._lock = threading.Lock()
        if source.features is not None:
            self.table = source.features

    # ------------------------------------------------------------------ jobs
    def start(self, kind: str, settings: dict) -> Job:
        """Start step ``kind`` in a thread (one step at a time) and return its job."""
        if any(j.state == "running" for j in self.jobs.values()):
            raise DataError("another step is still running; wait for it to finish")
        run = self._steps()[kind]
        job = Job(kind)
        self.jobs[job.id] = job
        threading.Thread(target=self._run, args=(job, run, settings), daemon=True).start()
        return job

    def run_now(self, kind: str, settings: dict) -> dict:
        """Run step ``kind`` here and return its result (raises its error)."""
        job = Job(kind)
        self._run(job, self._steps()[kind], settings)
        if job.error is not None:
            raise DataError(job.error)
        return job.result

    def _steps(self) -> dict:
        return {
            "features": self._features,
            "rank": self._rank,
            "train": self._train,
            "sensors": self._sensors,
            "replay": self._replay,
        }

    def _run(self, job: Job, run, settings: dict) -> None:
        try:
            with self._lock:
                job.result = run(settings, job)
            job.state = "done"
        except (DataError, ModelError, ValueError, TypeError, KeyError, OSError) as exc:
            job.error, job.state = one_line(exc), "failed"
        except Exception as exc:  # the page shows one line, never a traceback
            job.error = f"{type(exc).__name__}: {one_line(exc)}"
            job.state = "failed"
        job.seconds = time.perf_counter() - job.started

    # ------------------------------------------------------------------ steps
    def _features(self, raw: dict, job: Job) -> dict:
        from pdmkit.features import extract_ensemble

        if self.source.kind == "features":
            raise DataError("this session started from a feature table; rank and train it")
        settings = check_indicators(raw)
        signals = settings["signals"] or list(self.source.default_signals)
        unknown = [s for s in signals if s not in self.source.signals]
        if unknown:
            raise DataError(
                f"no signal(s) {unknown}; the ensemble has {list(self.source.signals)}"
            )
        options = extraction_options(settings["options"])
        conditions = self.source.conditions
        members = conditions.index
        if settings["scope"] == "filtered":
            members = filter_members(conditions, settings["filter"])
        batch = max(16, math.ceil(len(members) / 20))
        if self.source.ensemble is None:
            batch = 256
        batches, total = self.source.extraction_input(members, batch)
        job.step(0, total, f"0 of {len(members)} members")
        table = extract_ensemble(
            _counted(batches, job, total, len(members)),
            signals=signals,
            groups=tuple(settings["groups"]),
            **options,
        )
        label = self.label
        if label is not None and label in table.columns:
            table = table[table[label].notna()]
        settings["signals"] = signals
        self.table, self.ranking, self.result, self.sensors = table, None, None, None
        self.settings.update(indicators=settings, rank=None, train=None, sensors=None)
        return self.features_summary()

    def feature_columns(self) -> list[str]:
        """The indicator columns of the table (``<signal>/<group>/<Feature>``)."""
        if self.table is None:
            return []
        return [str(c) for c in self.table.columns if "/" in str(c)]

    def features_summary(self) -> dict:
        """Size and columns of the feature table (for the page)."""
        columns = self.feature_columns()
        n = 0 if self.table is None else len(self.table)
        return {"n_members": n, "n_features": len(columns), "features": columns}

    def _need_table(self) -> pd.DataFrame:
        if self.table is None:
            raise DataError("compute the indicators first (step 2)")
        return self.table

    def _need_label(self, table: pd.DataFrame) -> str:
        if self.label is None or self.label not in table.columns:
            conditions = [c for c in table.columns if "/" not in str(c)]
            raise DataError(
                f"choose the label: the condition holding the class, one of {conditions}"
            )
        return self.label

    def _rank(self, raw: dict, job: Job) -> dict:
        from pdmkit.features import rank_features

        settings = check_rank(raw)
        table = self._need_table()
        features = self.feature_columns()
        job.step(0, 1, f"ranking {len(features)} indicators")
        if settings["method"] in CLASS_RANKINGS:
            label = self._need_label(table)
            ranking = rank_features(
                table, table[label], method=settings["method"], features=features
            )
        else:
            ranking = rank_features(
                table,
                method=settings["method"],
                features=features,
                unit=settings["unit"],
                time=settings["order"],
            )
        frame = ranking.to_pandas()
        self.ranking = frame
        self.settings["rank"] = settings
        job.step(1, 1, "ranked")
        return {"method": settings["method"], "ranking": _records(frame)}

    def _train(self, raw: dict, job: Job) -> dict:
        from pdmkit.experiments import classify

        settings = check_train(raw)
        table = self._need_table()
        label = self._need_label(table)
        features, selection = self.feature_columns(), settings["selection"]
        if selection == "hand":
            missing = [f for f in settings["features"] if f not in features]
            if missing:
                raise DataError(f"no indicator(s) {missing[:3]} in the table")
            features, selection = list(settings["features"]), None
        job.step(0, 1, f"training {settings['model']} on {len(table)} members")
        result = classify(
            table,
            label,
            features=features,
            model=settings["model"],
            top_k=settings["top_k"],
            selection=selection,
            test_size=settings["test_size"],
            random_state=settings["seed"],
        )
        self.result = result
        self.settings["train"] = settings
        job.step(1, 1, "trained")
        return train_summary(result)

    def _sensors(self, raw: dict, job: Job) -> dict:
        from pdmkit.experiments import compare_sensors

        settings = check_sensors(raw)
        table = self._need_table()
        label = self._need_label(table)
        signals = sorted({c.split("/")[0] for c in self.feature_columns()})
        sensors = {s: [s] for s in signals}
        costs = settings["costs"] or None
        job.step(0, len(sensors), f"scoring {len(sensors)} sensors")
        comparison = compare_sensors(
            table,
            label,
            sensors,
            costs,
            model=settings["model"],
            top_k=settings["top_k"],
            random_state=settings["seed"],
        )
        self.sensors = comparison
        self.settings["sensors"] = settings
        job.step(len(sensors), len(sensors), "scored")
        return {"sensors": _records(comparison.to_pandas())}

    def _replay(self, project: dict, job: Job) -> dict:
        """Repeat a saved project's steps (its settings were checked on reading)."""
        data = project.get("data") or {}
        label = data.get("label")
        if label is not None and label in self.source.conditions.columns:
            self.label = label
        self.data.update(
            {k: data[k] for k in ("filter", "by", "signal", "kind") if k in data}
        )
        done = []
        for name, step in _replay_steps(self):
            if project.get(name) is None:
                continue
            if name == "indicators" and self.source.kind == "features":
                continue
            step(project[name], job)
            done.append(name)
        return {"replayed": done}


def _replay_steps(session: Session) -> list:
    return [
        ("indicators", session._features),
        ("rank", session._rank),
        ("train", session._train),
        ("sensors", session._sensors),
    ]


def train_summary(result) -> dict:
    """What the page shows of a trained classifier."""
    summary = result.summary()
    return {
        "accuracy": summary["accuracy"],
        "cv_accuracy": summary["cv_accuracy"],
        "cv_accuracy_std": summary["cv_accuracy_std"],
        "n_train": summary["n_train"],
        "n_test": summary["n_test"],
        "features": summary["features"],
        "labels": [str(c) for c in summary["labels"]],
        "confusion": summary["confusion"],
        "model": summary["model"],
        "split": summary["split"],
        "notes": summary["notes"],
    }


def _records(frame: pd.DataFrame) -> list[dict]:
    """Rows as JSON objects (NaN as None)."""
    out = []
    for row in frame.to_dict(orient="records"):
        out.append(
            {
                str(k): (
                    None
                    if isinstance(v, float) and not np.isfinite(v)
                    else v.item()
                    if isinstance(v, np.generic)
                    else v
                )
                for k, v in row.items()
            }
        )
    return out
