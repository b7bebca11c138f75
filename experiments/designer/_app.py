"""The designer's web app: a small Starlette application served by uvicorn.

The page (``static/index.html``, ``designer.js``, ``designer.css``) and Plotly.js (from
the installed ``plotly`` package; nothing comes from the internet) are served from the
installed packages. The JSON API does the work on the server; the page draws what it
returns. Every API call carries the session's token (printed in the URL), so another
page in the same browser cannot drive the designer; the server binds 127.0.0.1 unless
told otherwise.
"""

from __future__ import annotations

import argparse
import json
import secrets
import socket
import sys
from pathlib import Path
from typing import Any

from starlette.applications import Starlette
from starlette.concurrency import run_in_threadpool
from starlette.requests import Request
from starlette.responses import FileResponse, JSONResponse, Response
from starlette.routing import Route

from pdmkit import save_model
from pdmkit.errors import DataError
from pdmkit.experiments._deploy import FaultClassifier
from pdmkit.experiments.designer._export import bearing_spec, command_lines, python_script
from pdmkit.experiments.designer._project import (
    MAX_PROJECT_BYTES,
    parse_options,
    project_json,
    read_project,
)
from pdmkit.experiments.designer._session import Session, one_line, train_summary
from pdmkit.experiments.designer._source import member_reading, open_source
from pdmkit.experiments.designer._views import (
    MAX_LEVELS,
    class_values,
    filter_members,
    pick_members,
    signal_traces,
)

__all__ = ["create_app", "plotly_js", "serve"]

STATIC = Path(__file__).with_name("static")
#: most rows of the member table sent at once
MAX_ROWS = 500
#: the endpoints that work without an ensemble (``--history`` alone)
NO_SESSION = {"/api/state", "/api/history", "/api/history/unit"}


def plotly_js() -> Path:
    """The Plotly.js bundle shipped inside the installed ``plotly`` package.

    Examples
    --------
    >>> plotly_js().name
    'plotly.min.js'
    """
    import importlib.util

    spec = importlib.util.find_spec("plotly")
    if spec is None or not spec.submodule_search_locations:
        raise DataError("pdmkit designer needs plotly: pip install 'pdmkit[designer]'")
    path = Path(next(iter(spec.submodule_search_locations))) / "package_data/plotly.min.js"
    if not path.is_file():
        raise DataError(f"the installed plotly package lacks {path}; reinstall plotly")
    return path


def _error(message: str, status: int = 400) -> JSONResponse:
    return JSONResponse({"error": message}, status_code=status)


async def _body(request: Request, limit: int = MAX_PROJECT_BYTES) -> Any:
    declared = request.headers.get("content-length")
    if declared is not None and declared.isdigit() and int(declared) > limit:
        raise DataError(f"the request is {declared} bytes; at most {limit}")
    blob = await request.body()
    if len(blob) > limit:
        raise DataError(f"the request is {len(blob)} bytes; at most {limit}")
    if not blob:
        return {}
    try:
        return json.loads(blob)
    except ValueError:
        raise DataError("the request is not JSON") from None


def _levels(column) -> list[str] | None:
    values = column.dropna().astype(str).unique()
    return sorted(values.tolist()) if len(values) <= MAX_LEVELS else None


class _Api:
    """The JSON endpoints of one session (``session`` None: a monitoring history only)."""

    def __init__(self, session: Session | None, token: str, history: Any = None) -> None:
        self.session, self.token, self.history = session, token, history

    def routes(self) -> list[Route]:
        get, post = ["GET"], ["POST"]
        return [
            Route("/api/state", self.state, methods=get),
            Route("/api/members", self.members, methods=post),
            Route("/api/plot", self.plot, methods=post),
            Route("/api/values", self.values, methods=post),
            Route("/api/label", self.set_label, methods=post),
            Route("/api/run/{kind}", self.run, methods=post),
            Route("/api/job/{job_id}", self.job, methods=get),
            Route("/api/export", self.export, methods=get),
            Route("/api/export/model.pdmkit", self.model_file, methods=get),
            Route("/api/project", self.project, methods=get),
            Route("/api/project", self.open_project, methods=post),
            Route("/api/history", self.history_units, methods=get),
            Route("/api/history/unit", self.history_unit, methods=get),
        ]

    def guard(self, endpoint):
        """Wrap an endpoint: check the token, turn errors into one line."""

        async def call(request: Request) -> Response:
            if not secrets.compare_digest(
                request.headers.get("x-designer-token", ""), self.token
            ):
                return _error(
                    "missing or wrong session token; open the URL pdmkit printed", 403
                )
            if self.session is None and request.url.path not in NO_SESSION:
                return _error(
                    "this designer shows a monitoring history only: start it with "
                    "--dataset, --ensemble, --members or --features for the other steps"
                )
            try:
                return await endpoint(request)
            except (DataError, ValueError, TypeError, KeyError, OSError) as exc:
                return _error(one_line(exc))

        return call

    async def state(self, request: Request) -> Response:
        s = self.session
        history = None if self.history is None else self.history.name
        if s is None:
            return JSONResponse({"kind": None, "source": None, "history": history})
        conditions = s.source.conditions
        columns = [
            {
                "name": str(c),
                "levels": _levels(conditions[c]),
                "numeric": bool(conditions[c].dtype.kind in "iuf"),
            }
            for c in conditions.columns
        ]
        from pdmkit.features import GROUPS

        options = s.source.default_options
        text = " ".join(
            f"{k}={_option_word(v)}"
            for k, v in options.items()
            if not (
                k in ("bearing", "shaft_hz") and "envelope" not in s.source.default_groups
            )
        )
        steps = {k: v for k, v in s.settings.items()}
        return JSONResponse(
            {
                "source": s.source.describe(),
                "kind": s.source.kind,
                "n_members": len(conditions),
                "signals": [{"name": k, "fs": v} for k, v in s.source.signals.items()],
                "conditions": columns,
                "label": s.label,
                "data": s.data,
                "groups": list(GROUPS),
                "defaults": {
                    "signals": s.source.default_signals,
                    "groups": s.source.default_groups,
                    "options": text,
                },
                "steps": steps,
                "features": s.features_summary(),
                "ranking": None if s.ranking is None else _rows(s.ranking),
                "train": None if s.result is None else train_summary(s.result),
                "sensors": None if s.sensors is None else _rows(s.sensors.to_pandas()),
                "jobs": [j.status() for j in s.jobs.values() if j.state == "running"],
                "history": history,
            }
        )

    async def members(self, request: Request) -> Response:
        body = await _body(request)
        conditions = self.session.source.conditions
        ids = filter_members(conditions, body.get("filter"))
        self.session.data["filter"] = body.get("filter") or {}
        offset = max(0, int(body.get("offset", 0)))
        limit = min(MAX_ROWS, max(1, int(body.get("limit", 100))))
        page = conditions.loc[ids[offset : offset + limit]]
        rows = [
            {"member": str(m), **{str(k): _plain(v) for k, v in row.items()}}
            for m, row in zip(page.index, page.to_dict(orient="records"), strict=True)
        ]
        return JSONResponse({"total": len(ids), "offset": offset, "rows": rows})

    async def plot(self, request: Request) -> Response:
        body = await _body(request)
        s = self.session
        by = body.get("by") or None
        signal = body.get("signal") or next(iter(s.source.signals), None)
        if signal is None:
            raise DataError("this session has no signals (it started from a feature table)")
        members = body.get("members") or []
        if not members:
            ids = filter_members(s.source.conditions, body.get("filter"))
            members = pick_members(
                s.source.conditions, ids, by, int(body.get("per_class", 1))
            )
        kind = body.get("kind", "signal")
        nperseg = body.get("nperseg") or None
        s.data.update(by=by, signal=signal, kind=kind)
        out = signal_traces(s.source, members, signal, by, kind, nperseg)
        out["signal"] = signal
        return JSONResponse(out)

    async def values(self, request: Request) -> Response:
        body = await _body(request)
        table = self.session.table
        if table is None:
            raise DataError("compute the indicators first (step 2)")
        columns = body.get("columns") or []
        if not 1 <= len(columns) <= 2:
            raise DataError("ask for one indicator (histogram) or two (scatter)")
        by = body.get("by") or self.session.label
        return JSONResponse(class_values(table, columns, by))

    async def set_label(self, request: Request) -> Response:
        body = await _body(request)
        label = body.get("label")
        conditions = self.session.source.conditions
        if label not in conditions.columns:
            raise DataError(
                f"no condition {label!r}; the conditions are {list(conditions.columns)}"
            )
        self.session.label = label
        return JSONResponse({"label": label})

    async def run(self, request: Request) -> Response:
        kind = request.path_params["kind"]
        if kind not in ("features", "rank", "train", "sensors"):
            raise DataError(f"no step {kind!r}")
        job = self.session.start(kind, await _body(request))
        return JSONResponse(job.status())

    async def job(self, request: Request) -> Response:
        job = self.session.jobs.get(request.path_params["job_id"])
        if job is None:
            raise DataError("no such job")
        status = job.status()
        if job.state == "done":
            status["result"] = job.result
        return JSONResponse(status)

    async def export(self, request: Request) -> Response:
        lines = command_lines(self.session)
        return JSONResponse({**lines, "script": python_script(self.session)})

    async def model_file(self, request: Request) -> Response:
        import tempfile

        if self.session.result is None:
            raise DataError("train a classifier first (step 3)")
        s = self.session
        indicators = s.settings.get("indicators") or {}
        options = parse_options(indicators.get("options") or "")
        bearing, shaft_hz = options.pop("bearing", None), options.pop("shaft_hz", None)
        recipe = {  # what pdmkit predict --members computes from new files
            "input": "features" if s.source.kind == "features" else "members",
            "signals": indicators.get("signals"),
            "groups": indicators.get("groups"),
            "options": options,
            "bearing": None if bearing is None else str(bearing),
            "shaft_hz": shaft_hz,
        }
        clf = FaultClassifier.from_result(s.result, s.table, recipe=recipe)
        with tempfile.TemporaryDirectory() as folder:
            path = save_model(clf, Path(folder) / "model.pdmkit")
            blob = path.read_bytes()
        headers = {"content-disposition": 'attachment; filename="model.pdmkit"'}
        return Response(blob, media_type="application/octet-stream", headers=headers)

    async def project(self, request: Request) -> Response:
        s = self.session
        value = s.source.value
        source = {"kind": s.source.kind, "value": value}
        data = {**s.data, "label": s.label}
        return Response(
            project_json(source, data, dict(s.settings)), media_type="application/json"
        )

    async def open_project(self, request: Request) -> Response:
        blob = await request.body()
        project = read_project(blob)
        s = self.session
        mine = {"kind": s.source.kind, "value": s.source.value}
        if project["source"] != mine:
            raise DataError(
                f"the project is for {project['source']['kind']} "
                f"{project['source']['value']!r}, "
                f"this session for {mine['kind']} {mine['value']!r}; start pdmkit designer "
                "--project FILE to open it"
            )
        job = s.start("replay", project)
        return JSONResponse(job.status())

    def _history(self) -> Any:
        if self.history is None:
            raise DataError(
                "this designer was started without a monitoring history: "
                "pdmkit designer --history PATH|URL"
            )
        return self.history

    async def history_units(self, request: Request) -> Response:
        """A page of the alarm table: ``?offset=&limit=&alarmed=1&contains=TEXT``."""
        q = request.query_params
        query = {
            "offset": int(q.get("offset", 0)),
            "limit": int(q.get("limit", 100)),
            "alarmed_only": q.get("alarmed", "") in ("1", "true"),
            "contains": q.get("contains", ""),
        }
        source = self._history()
        return JSONResponse(await run_in_threadpool(lambda: source.units(**query)))

    async def history_unit(self, request: Request) -> Response:
        """One unit's health index (and RUL) over time: ``?unit=NAME&points=N``."""
        unit = request.query_params.get("unit", "")
        if not unit:
            raise DataError("name the unit: /api/history/unit?unit=NAME")
        points = request.query_params.get("points")
        source = self._history()
        args = (unit,) if points is None else (unit, int(points))
        return JSONResponse(await run_in_threadpool(source.unit, *args))


def _option_word(value: Any) -> str:

    if hasattr(value, "n_balls"):
        return bearing_spec(value)
    return value if isinstance(value, str) else json.dumps(value, separators=(",", ":"))


def _plain(value: Any) -> Any:
    if hasattr(value, "item"):
        value = value.item()
    if isinstance(value, float) and value != value:
        return None
    if isinstance(value, int | float | str | bool) or value is None:
        return value
    return str(value)


def _rows(frame) -> list[dict]:
    return [{str(k): _plain(v) for k, v in row.items()} for row in frame.to_dict("records")]


def create_app(session: Session | None, token: str, history: Any = None) -> Starlette:
    """The Starlette application of a designer session.

    ``session`` None (``pdmkit designer --history`` alone) serves the History page
    only; ``history`` is the monitoring history it shows (a
    :class:`~pdmkit.experiments.designer._history.HistorySource`; that module is
    imported only when one is named, as it loads scipy and scikit-learn).

    Examples
    --------
    >>> import numpy as np
    >>> from starlette.testclient import TestClient
    >>> from pdmkit.ensembles import Ensemble
    >>> from pdmkit.experiments.designer._source import Source
    >>> ens = Ensemble({"v": np.zeros((2, 64))}, fs=64.0, conditions={"fault": ["a", "b"]})
    >>> client = TestClient(create_app(Session(Source.from_ensemble(ens)), "t0k"))
    >>> client.get("/api/state").status_code
    403
    >>> client.get("/api/state", headers={"x-designer-token": "t0k"}).json()["n_members"]
    2
    """
    api = _Api(session, token, history)
    index = (STATIC / "index.html").read_text(encoding="utf-8")

    async def page(request: Request) -> Response:
        given = request.query_params.get("token", "")
        if not secrets.compare_digest(given, token):
            return Response(
                "pdmkit designer: open the URL with its token, as pdmkit printed it",
                status_code=403,
                media_type="text/plain",
            )
        html = index.replace("__TOKEN__", token)
        return Response(html, media_type="text/html", headers={"cache-control": "no-store"})

    async def static(request: Request) -> Response:
        name = request.path_params["name"]
        files = {
            "designer.js": STATIC / "designer.js",
            "designer.css": STATIC / "designer.css",
            "plotly.min.js": plotly_js(),
        }
        if name not in files:
            return Response("not found", status_code=404)
        return FileResponse(files[name], headers={"cache-control": "max-age=3600"})

    routes = [Route("/", page), Route("/static/{name}", static)]
    for route in api.routes():
        routes.append(Route(route.path, api.guard(route.endpoint), methods=route.methods))
    return Starlette(routes=routes)


def _session_from(args: argparse.Namespace) -> Session | None:
    project = None
    if getattr(args, "project", None) is not None:
        path = Path(args.project)
        if path.stat().st_size > MAX_PROJECT_BYTES:
            raise DataError(f"--project {path}: more than {MAX_PROJECT_BYTES} bytes")
        project = read_project(path.read_bytes())
    given = [
        (k, getattr(args, k, None)) for k in ("dataset", "members", "ensemble", "features")
    ]
    given = [(k, v) for k, v in given if v is not None]
    if given:
        kind, value = given[0]
    elif project is not None:
        kind, value = project["source"]["kind"], project["source"]["value"]
    elif getattr(args, "history", None) is not None:
        return None  # the History page alone
    else:
        raise DataError(
            "name the members: --dataset NAME, --ensemble DIR, --members FILES, "
            "--features FILE or --project FILE (or a monitoring history: --history PATH)"
        )
    value = value if kind != "members" else list(value)
    session = Session(open_source(kind, value, member_reading(args)))
    if project is not None:
        session.start("replay", project)
    return session


def _warm_up() -> None:
    """Import what the first requests need before the URL is printed.

    The indicator groups (scipy) and the spectra take a second or two to import; done
    here, the page's first plot does not wait for them.
    """
    import scipy.signal  # noqa: F401  (Welch spectra)

    from pdmkit.features import GROUPS  # noqa: F401  (the groups' modules)


def serve(args: argparse.Namespace) -> int:
    """Start the designer for the command line's arguments; return the exit status.

    Binds ``--host`` (127.0.0.1) and ``--port`` (0: a free one), prints the URL (with the
    session token) and opens it in a browser unless ``--no-browser``.
    """
    import uvicorn

    history = None
    if getattr(args, "history", None) is not None:  # checked before serving
        from pdmkit.experiments.designer._history import HistorySource

        history = HistorySource(args.history)
    session = _session_from(args)
    if session is not None:
        _warm_up()
    token = secrets.token_urlsafe(16)
    app = create_app(session, token, history)
    sock = socket.socket(socket.AF_INET6 if ":" in args.host else socket.AF_INET)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    try:
        sock.bind((args.host, args.port))
        sock.listen()  # before the URL is printed: a browser's first request waits
    except OSError as exc:
        raise DataError(f"cannot bind {args.host}:{args.port} ({exc.strerror})") from None
    port = sock.getsockname()[1]
    host = f"[{args.host}]" if ":" in args.host else args.host
    url = f"http://{host}:{port}/?token={token}"
    shown = [session.source.describe()] if session is not None else []
    shown += [] if history is None else [f"the monitoring history {history.name}"]
    print(f"pdmkit designer on {' and '.join(shown)}", flush=True)
    print(f"pdmkit designer: open {url}  (Ctrl-C stops it)", flush=True)
    if args.host not in ("127.0.0.1", "localhost", "::1"):
        print(
            f"pdmkit designer: bound to {args.host}: other machines can reach it with the "
            "token; bind 127.0.0.1 unless you mean that",
            file=sys.stderr,
            flush=True,
        )
    if not args.no_browser:
        import webbrowser

        webbrowser.open(url)
    config = uvicorn.Config(app, log_level="warning", access_log=False)
    uvicorn.Server(config).run(sockets=[sock])
    return 0
