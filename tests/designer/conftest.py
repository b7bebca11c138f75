"""Shared helpers of the designer tests: start ``pdmkit designer`` as a user would."""

from __future__ import annotations

import os
import queue
import re
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

pytest.importorskip("starlette", reason="pdmkit[designer] is not installed")
pytest.importorskip("uvicorn", reason="pdmkit[designer] is not installed")

URL = re.compile(r"open (http://\S+)")


class Server:
    """A ``pdmkit designer`` process and the URL it printed."""

    def __init__(self, args: list[str], cwd: Path, timeout: float = 60.0) -> None:
        env = {**os.environ, "PYTHONUNBUFFERED": "1"}
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "pdmkit", "designer", "--no-browser", *args],
            cwd=cwd,
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            text=True,
            env=env,
        )
        self.lines: queue.Queue[str] = queue.Queue()
        threading.Thread(target=self._read, daemon=True).start()
        self.url = self._wait_url(timeout)
        self.base = self.url.split("/?")[0]
        self.token = self.url.split("token=")[1]

    def _read(self) -> None:
        for line in self.proc.stdout:
            self.lines.put(line)

    def _wait_url(self, timeout: float) -> str:
        end, seen = time.monotonic() + timeout, []
        while time.monotonic() < end:
            try:
                line = self.lines.get(timeout=0.2)
            except queue.Empty:
                if self.proc.poll() is not None:
                    break
                continue
            seen.append(line)
            found = URL.search(line)
            if found:
                return found.group(1)
        self.stop()
        raise AssertionError(f"pdmkit designer printed no URL: {''.join(seen)[-2000:]}")

    def stop(self) -> None:
        if self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(10)
            except subprocess.TimeoutExpired:
                self.proc.kill()


@pytest.fixture
def start_designer(tmp_path):
    """Start ``pdmkit designer ARGS`` in ``tmp_path``; stopped after the test."""
    servers: list[Server] = []

    def start(*args: str) -> Server:
        server = Server(list(args), cwd=tmp_path)
        servers.append(server)
        return server

    yield start
    for server in servers:
        server.stop()
