"""A headless Chromium driven over the DevTools protocol on a pipe: pages as a person sees them.

Debian's ``chromium`` is started with ``--remote-debugging-pipe`` (the protocol on file
descriptors 3 and 4: no port, no network) and the standard library speaks to it: navigate,
wait for the load, evaluate JavaScript, take a screenshot, and collect every console message
by level (``console.error``, uncaught exceptions and the browser's own error log entries),
which Chromium's ``--enable-logging`` output cannot tell apart. :func:`executable` is None
where Chromium is missing, so tests skip there.
"""

from __future__ import annotations

import base64
import json
import os
import select
import shutil
import subprocess
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

__all__ = ["Browser", "Message", "executable"]

#: The flags that work headless on this machine; WebGL runs on SwiftShader (opted in, so the
#: deprecation notice of the automatic fallback does not appear).
FLAGS = [
    "--headless=new", "--no-sandbox", "--disable-gpu", "--enable-unsafe-swiftshader",
    "--disable-background-networking", "--disable-component-update", "--disable-sync",
    "--no-first-run", "--no-default-browser-check", "--hide-scrollbars", "--mute-audio",
    "--remote-debugging-pipe",
]


def executable() -> str | None:
    """The Chromium binary (CHROMIUM, or chromium / chromium-browser on PATH), or None."""
    for name in (os.environ.get("CHROMIUM"), "chromium", "chromium-browser"):
        if name and shutil.which(name):
            return shutil.which(name)
    return None


@dataclass
class Message:
    """One console message or error of a page: level, text, where it came from."""

    level: str
    text: str
    source: str = ""

    def __str__(self) -> str:
        return f"[{self.level}] {self.text} ({self.source})"


@dataclass
class Browser:
    """One Chromium process with one page; use as a context manager."""

    width: int = 1280
    height: int = 800
    timeout: float = 60.0
    messages: list[Message] = field(default_factory=list)

    def __enter__(self) -> Browser:
        exe = executable()
        if exe is None:
            raise RuntimeError("chromium is not installed")
        self._tmp = tempfile.TemporaryDirectory(prefix="creatio-chromium-")
        to_child, self._write = os.pipe()
        self._read, from_child = os.pipe()

        def plumb() -> None:  # the protocol lives on the child's fds 3 (in) and 4 (out)
            os.dup2(to_child, 3)
            os.dup2(from_child, 4)

        self._proc = subprocess.Popen(
            [exe, *FLAGS, f"--user-data-dir={self._tmp.name}",
             f"--window-size={self.width},{self.height}", "about:blank"],
            stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
            pass_fds=(3, 4), preexec_fn=plumb)
        os.close(to_child)
        os.close(from_child)
        self._buffer = b""
        self._next = 0
        self._events: list[dict] = []
        target = self._call("Target.createTarget", {"url": "about:blank"})["targetId"]
        self._session = self._call("Target.attachToTarget",
                                   {"targetId": target, "flatten": True})["sessionId"]
        for method in ("Runtime.enable", "Log.enable", "Page.enable"):
            self.call(method)
        self.call("Emulation.setDeviceMetricsOverride",
                  {"width": self.width, "height": self.height, "deviceScaleFactor": 1,
                   "mobile": False})
        return self

    def __exit__(self, *exc: object) -> None:
        try:
            self._call("Browser.close", timeout=5)
        except Exception:  # noqa: BLE001 - closing anyway
            pass
        try:
            self._proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            self._proc.kill()
            self._proc.wait()
        os.close(self._write)
        os.close(self._read)
        self._tmp.cleanup()

    # ------------------------------------------------------------------------ protocol
    def _send(self, method: str, params: dict | None, session: str | None) -> int:
        self._next += 1
        msg: dict[str, Any] = {"id": self._next, "method": method, "params": params or {}}
        if session:
            msg["sessionId"] = session
        os.write(self._write, json.dumps(msg).encode() + b"\0")
        return self._next

    def _receive(self, deadline: float) -> dict:
        while b"\0" not in self._buffer:
            left = deadline - time.monotonic()
            if left <= 0 or not select.select([self._read], [], [], left)[0]:
                raise TimeoutError("chromium did not answer in time")
            chunk = os.read(self._read, 1 << 20)
            if not chunk:
                raise RuntimeError("chromium closed the protocol pipe")
            self._buffer += chunk
        raw, _, self._buffer = self._buffer.partition(b"\0")
        msg = json.loads(raw)
        if "method" in msg:
            self._event(msg)
        return msg

    def _call(self, method: str, params: dict | None = None, session: str | None = None,
              timeout: float | None = None) -> dict:
        mid = self._send(method, params, session)
        deadline = time.monotonic() + (timeout or self.timeout)
        while True:
            msg = self._receive(deadline)
            if msg.get("id") == mid:
                if "error" in msg:
                    raise RuntimeError(f"{method}: {msg['error']}")
                return msg.get("result", {})

    def call(self, method: str, params: dict | None = None, timeout: float | None = None
             ) -> dict:
        """One protocol command on the page's session; its result."""
        return self._call(method, params, self._session, timeout)

    def _event(self, msg: dict) -> None:
        self._events.append(msg)
        method, p = msg["method"], msg.get("params", {})
        if method == "Runtime.consoleAPICalled":
            text = " ".join(str(a.get("value", a.get("description", ""))) for a in p["args"])
            frame = (p.get("stackTrace") or {}).get("callFrames") or [{}]
            self.messages.append(Message(p["type"], text, frame[0].get("url", "")))
        elif method == "Runtime.exceptionThrown":
            d = p["exceptionDetails"]
            text = (d.get("exception") or {}).get("description") or d.get("text", "")
            self.messages.append(Message("exception", text, d.get("url", "")))
        elif method == "Log.entryAdded":
            e = p["entry"]
            self.messages.append(Message(e["level"], e["text"], e.get("url", e["source"])))

    # ---------------------------------------------------------------------------- page
    def open(self, url: str, settle: float = 0.5) -> None:
        """Navigate and wait for the load event, then ``settle`` seconds of rendering.

        A URL that differs from the current one only in its fragment would not load the
        page again, so the page is first left for about:blank."""
        self.call("Page.navigate", {"url": "about:blank"})
        self._events.clear()
        self.call("Page.navigate", {"url": url})
        deadline = time.monotonic() + self.timeout
        while not any(e["method"] == "Page.loadEventFired" for e in self._events):
            self._receive(deadline)
        end = time.monotonic() + settle
        while time.monotonic() < end:
            try:
                self._receive(end)
            except TimeoutError:
                break

    def evaluate(self, expression: str) -> Any:
        """The value of a JavaScript expression in the page (promises awaited)."""
        result = self.call("Runtime.evaluate", {"expression": expression, "returnByValue": True,
                                                "awaitPromise": True})
        if "exceptionDetails" in result:
            raise RuntimeError(f"{expression}: {result['exceptionDetails']}")
        return result["result"].get("value")

    def wait_for(self, expression: str, timeout: float = 30.0) -> Any:
        """Poll a JavaScript expression until it is truthy (TimeoutError after timeout s)."""
        end = time.monotonic() + timeout
        while True:
            value = self.evaluate(expression)
            if value:
                return value
            if time.monotonic() > end:
                raise TimeoutError(f"still false after {timeout} s: {expression}")
            time.sleep(0.25)

    def screenshot(self, path: str | Path | None = None) -> bytes:
        """A PNG of the viewport (written to path if given)."""
        data = base64.b64decode(self.call("Page.captureScreenshot", {"format": "png"})["data"])
        if path is not None:
            Path(path).write_bytes(data)
        return data

    def errors(self) -> list[Message]:
        """Console errors, uncaught exceptions and error log entries seen so far."""
        return [m for m in self.messages if m.level in ("error", "assert", "exception")]
