"""Headless Chromium (Debian's `chromium`) driven over the Chrome DevTools Protocol, for
the tests that look at a page as a person would.

The protocol directly rather than Selenium and chromedriver: the tests need three
calls (navigate, evaluate JavaScript, capture a screenshot), which the protocol gives
over one websocket with the `websockets` package the view already brings; no driver
whose version must match the browser's, and nothing else to install. WebGL runs on
SwiftShader, Chromium's software renderer, so no GPU is needed."""

import base64
import itertools
import json
import pathlib
import shutil
import subprocess
import tempfile
import time
import urllib.request

from websockets.sync.client import connect

START_TIMEOUT_S = 60
CALL_TIMEOUT_S = 120


def chromium_path():
    """The browser, or None when it is not installed."""
    return shutil.which("chromium") or shutil.which("chromium-browser")


class Browser:
    """One headless Chromium with one page, width x height pixels. close() ends it."""

    def __init__(self, width=1280, height=800):
        self._profile = tempfile.mkdtemp(prefix="hapticd-chromium-")
        self._log = tempfile.TemporaryFile()  # noqa: SIM115 (open while chromium runs)
        self.process = subprocess.Popen(
            [
                chromium_path(),
                "--headless=new",
                "--no-sandbox",  # root in a container has no user namespaces for it
                "--use-angle=swiftshader",
                "--enable-unsafe-swiftshader",
                "--ignore-gpu-blocklist",
                "--no-first-run",
                "--no-default-browser-check",
                "--disable-background-networking",
                "--disable-renderer-backgrounding",
                "--disable-background-timer-throttling",
                "--remote-debugging-port=0",
                f"--user-data-dir={self._profile}",
                f"--window-size={width},{height}",
                "about:blank",
            ],
            stdout=subprocess.DEVNULL,
            stderr=self._log,
        )
        self._ids = itertools.count(1)
        try:
            port = self._debugging_port()
            targets = json.loads(urllib.request.urlopen(f"http://127.0.0.1:{port}/json/list").read())
            page = next(t for t in targets if t["type"] == "page")
            self._socket = connect(page["webSocketDebuggerUrl"], max_size=None, open_timeout=30)
            self.call("Page.enable")
            self.call("Runtime.enable")
            self.call(
                "Emulation.setDeviceMetricsOverride",
                width=width,
                height=height,
                deviceScaleFactor=1,
                mobile=False,
            )
        except BaseException:
            self.close()
            raise

    def _debugging_port(self):
        """The port Chromium chose, from the DevToolsActivePort file it writes."""
        marker = pathlib.Path(self._profile) / "DevToolsActivePort"
        deadline = time.monotonic() + START_TIMEOUT_S
        while time.monotonic() < deadline:
            if self.process.poll() is not None:
                raise AssertionError(f"chromium exited {self.process.returncode}: {self.log()}")
            if marker.is_file() and marker.read_text().strip():
                return int(marker.read_text().split()[0])
            time.sleep(0.1)
        raise AssertionError(f"chromium opened no debugging port: {self.log()}")

    def log(self):
        """What Chromium wrote to stderr so far (its last 3000 characters)."""
        self._log.seek(0)
        return self._log.read().decode(errors="replace")[-3000:]

    def call(self, method, **params):
        """One protocol command's result (events that come before it are skipped)."""
        number = next(self._ids)
        self._socket.send(json.dumps({"id": number, "method": method, "params": params}))
        deadline = time.monotonic() + CALL_TIMEOUT_S
        while True:
            message = json.loads(self._socket.recv(timeout=max(0.1, deadline - time.monotonic())))
            if message.get("id") == number:
                if "error" in message:
                    raise AssertionError(f"{method}: {message['error']}")
                return message["result"]

    def navigate(self, url):
        self.call("Page.navigate", url=url)

    def evaluate(self, expression):
        """The value of a JavaScript expression in the page."""
        result = self.call("Runtime.evaluate", expression=expression, returnByValue=True)
        return result["result"].get("value")

    def text(self):
        """The page's visible text."""
        return self.evaluate("document.body ? document.body.innerText : ''") or ""

    def screenshot(self):
        """The page as PNG bytes."""
        return base64.b64decode(self.call("Page.captureScreenshot", format="png")["data"])

    def close(self):
        if getattr(self, "_socket", None) is not None:
            try:
                self._socket.close()
            except OSError:
                pass
        if self.process.poll() is None:
            self.process.terminate()
            try:
                self.process.wait(timeout=10)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait()
        shutil.rmtree(self._profile, ignore_errors=True)


def wait_for(predicate, timeout_s, interval_s=0.25):
    """Polls predicate until it returns something other than None or False (returned)
    or timeout_s passes (None): for what a loaded machine's page shows sooner or later."""
    deadline = time.monotonic() + timeout_s
    while True:
        value = predicate()
        if value is not None and value is not False:
            return value
        if time.monotonic() > deadline:
            return None
        time.sleep(interval_s)

