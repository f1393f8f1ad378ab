"""Headless Chromium driven over the DevTools protocol, for test_view.py: loads a page, waits for
text to appear in it (a readiness signal, not a sleep), and takes a screenshot as numpy RGB.

Chromium renders WebGL in software (SwiftShader), as a machine with no GPU, and CI's, has to.
"""
from __future__ import annotations

import base64
import contextlib
import io
import itertools
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time

import numpy as np
import pytest
from PIL import Image
from websockets.sync.client import connect


@contextlib.contextmanager
def served_view(args, timeout: float):
    """`python -m chasles.view ARGS` on a free port, yielded once it prints its address (its .url);
    on leaving, it must end cleanly on SIGTERM, and say each of its .expected_notes once."""
    process = subprocess.Popen([sys.executable, "-m", "chasles.view", "--port", "0", *args], stdout=subprocess.PIPE,
                               stderr=subprocess.PIPE, text=True)
    ready = {}

    def read():
        for line in process.stdout:
            match = re.fullmatch(r"chasles view: (http://127\.0\.0\.1:\d+)\s*", line)
            if match:
                ready["url"] = match.group(1)
                break

    reader = threading.Thread(target=read, daemon=True)
    reader.start()
    reader.join(timeout=timeout)
    if "url" not in ready:
        process.kill()
        pytest.fail(f"the view printed no address within {timeout:g} s; stderr:\n{process.communicate()[1]}")
    process.url, process.expected_notes = ready["url"], []
    yield process
    process.terminate()
    _, stderr = process.communicate(timeout=10)
    assert process.returncode == 0, f"the view ended with {process.returncode}; stderr:\n{stderr}"
    for note in process.expected_notes:
        assert stderr.count(note) == 1, f"'{note}' is not said once on stderr:\n{stderr}"


def chromium_path():
    return shutil.which("chromium") or shutil.which("chromium-browser")


class Browser:
    def __init__(self, width: int, height: int, timeout: float = 60.0):
        self.width, self.height = width, height
        self._profile = tempfile.mkdtemp(prefix="chasles-view-chromium-")
        self.process = subprocess.Popen(
            [chromium_path(), "--headless=new", "--no-sandbox", "--use-angle=swiftshader",
             "--enable-unsafe-swiftshader", "--no-first-run", "--no-default-browser-check",
             "--disable-background-timer-throttling", "--disable-renderer-backgrounding",
             "--hide-scrollbars", f"--user-data-dir={self._profile}", f"--window-size={width},{height}",
             "--remote-debugging-port=0", "about:blank"],
            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
            start_new_session=True)  # its own process group: close() ends every process it started
        address = None
        deadline = time.monotonic() + timeout
        while address is None and time.monotonic() < deadline:
            line = self.process.stderr.readline()
            if not line:
                break
            match = re.search(r"DevTools listening on (ws://\S+)", line)
            if match:
                address = match.group(1)
        if address is None:
            self.close()
            raise RuntimeError("chromium did not start its DevTools server")
        # The rest of chromium's stderr (GPU and D-Bus chatter) is drained, never read.
        self._drain = subprocess.Popen(["cat"], stdin=self.process.stderr, stdout=subprocess.DEVNULL)
        self._ws = connect(address, max_size=64 * 2**20, open_timeout=timeout)
        self._ids = itertools.count(1)
        target = self._call("Target.createTarget", url="about:blank")["targetId"]
        self._session = self._call("Target.attachToTarget", targetId=target, flatten=True)["sessionId"]
        self.call("Emulation.setDeviceMetricsOverride", width=width, height=height, deviceScaleFactor=1,
                  mobile=False)

    def _call(self, method: str, session=None, timeout: float = 60.0, **params):
        id = next(self._ids)
        message = {"id": id, "method": method, "params": params}
        if session:
            message["sessionId"] = session
        self._ws.send(json.dumps(message))
        deadline = time.monotonic() + timeout
        while True:
            reply = json.loads(self._ws.recv(timeout=max(0.01, deadline - time.monotonic())))
            if reply.get("id") == id:
                if "error" in reply:
                    raise RuntimeError(f"{method}: {reply['error']}")
                return reply.get("result", {})

    def call(self, method: str, **params):
        return self._call(method, self._session, **params)

    def evaluate(self, expression: str, await_promise: bool = False):
        result = self.call("Runtime.evaluate", expression=expression, returnByValue=True, awaitPromise=await_promise)
        if "exceptionDetails" in result:
            raise RuntimeError(f"{expression}: {result['exceptionDetails']}")
        return result["result"].get("value")

    def open(self, url: str) -> None:
        self.call("Page.navigate", url=url)

    def text(self) -> str:
        return self.evaluate("document.body ? document.body.innerText : ''") or ""

    def wait_text(self, pattern: str, timeout: float = 30.0) -> str:
        """Waits until the page's text matches the regular expression; returns the text."""
        deadline = time.monotonic() + timeout
        while True:
            text = self.text()
            if re.search(pattern, text):
                return text
            if time.monotonic() > deadline:
                raise TimeoutError(f"the page never showed /{pattern}/ in {timeout} s; it shows:\n{text}")
            time.sleep(0.05)

    def frames(self, n: int = 3) -> None:
        """Waits for n animation frames, so that what the page holds has been rendered."""
        self.evaluate("new Promise(r => { let k = %d; const f = () => (--k > 0 ? requestAnimationFrame(f) : r(0));"
                      " requestAnimationFrame(f); })" % n, await_promise=True)

    def screenshot(self) -> np.ndarray:
        data = self.call("Page.captureScreenshot", format="png")["data"]
        return np.asarray(Image.open(io.BytesIO(base64.b64decode(data))).convert("RGB"))

    def close(self) -> None:
        try:
            self._ws.close()
        except Exception:
            pass
        # Chromium's renderers and GPU process outlive a browser killed alone (seen: orphans at
        # 80 % of a core for minutes): the whole group goes.
        try:
            os.killpg(self.process.pid, signal.SIGTERM)
        except ProcessLookupError:
            pass
        if self.process.poll() is None:
            self.process.terminate()
            try:
                self.process.wait(timeout=5)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait()
        try:
            os.killpg(self.process.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
        if getattr(self, "_drain", None) is not None:
            self._drain.wait(timeout=5)
        shutil.rmtree(self._profile, ignore_errors=True)


def project(points, eye, target, fov_deg: float, width: int, height: int, up=(0.0, 0.0, 1.0)) -> np.ndarray:
    """Pixel coordinates (u right, v down) of base-frame points seen by a pinhole camera at `eye`
    looking at `target` with vertical field of view fov_deg (three.js's PerspectiveCamera, whose
    aspect is the canvas's)."""
    eye, target, up = (np.asarray(v, float) for v in (eye, target, up))
    z = eye - target
    z /= np.linalg.norm(z)  # the camera looks down its -z
    x = np.cross(up, z)
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    d = (np.asarray(points, float).reshape(-1, 3) - eye) @ np.stack([x, y, z], axis=1)
    f = 1.0 / np.tan(np.radians(fov_deg) / 2)
    ndc_x = f * d[:, 0] / (-d[:, 2]) * height / width
    ndc_y = f * d[:, 1] / (-d[:, 2])
    return np.stack([(ndc_x + 1) / 2 * width, (1 - ndc_y) / 2 * height], axis=1)
