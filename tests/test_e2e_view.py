"""End to end, the live view in a real browser: a real server with one object of each
representation (a kinematic one moving), `python -m hapticd view` serving the page,
headless Chromium (tests/cdp_browser.py) showing it, and a simulated device over UDP
that hovers over the crate, presses into its top, strokes along it and lifts off.

What the page shows is asserted from its pixels (each representation's colour is there;
the yellow avatar moves with the stroke; the magenta force arrow is there in contact
and gone in free space; the spinning kinematic object turns) and from its panel's text (the
session's contact state, force and positions). On a loaded 2-core machine the page may
lag the device by seconds: every check polls until the page shows it, with generous
deadlines, and no check is on time.

HAPTICD_VIEW_SCREENSHOT=path saves the screenshot of the stroke (the README's)."""

import io
import json
import os
import re
import subprocess
import sys
import threading
import time

import hapticd
import numpy as np
import pytest
import trimesh
from cdp_browser import Browser, chromium_path, wait_for
from hapticd._view_model import LEGEND_ID
from matplotlib.colors import rgb_to_hsv
from PIL import Image
from server_process import running_server

# How long the page may take to show a state (s): software WebGL on a busy machine.
PAGE_TIMEOUT_S = 120
# At least this many pixels make a colour present; at most ABSENT_PIXELS leave it absent.
PRESENT_PIXELS = 40
ABSENT_PIXELS = 5
# Hue windows (degrees) of the view's colours (hapticd._view_model), lit or shaded.
HUES = {
    "sphere": (210, 232),
    "box": (15, 40),
    "capsule": (110, 150),
    "convex": (255, 285),
    "mesh": (175, 195),
    "avatar": (45, 62),
    "force": (300, 325),
}
# Left of the panel by this much, and the gizmo's corner, are not the scene.
PANEL_MARGIN_PX = 12
GIZMO_PX = 100
# The stroke over the crate's top face (z = 0.1): above it, 5 mm in, along it, above.
HOVER = (0.07, 0.0, 0.13)
PRESSED = (0.07, 0.0, 0.095)
STROKED = (0.13, 0.0, 0.095)
LIFTED = (0.13, 0.0, 0.13)
# The device moves at most this far per state (m): 0.1 m/s at 250 Hz.
STEP_M = 0.0004
RATE_HZ = 250.0


def build_scene(client):
    client.clear_scene()
    client.add_plane("floor")
    client.add_box("crate", (0.05, 0.05, 0.05), position=(0.1, 0, 0.05))
    client.add_sphere("ball", 0.04, position=(-0.1, 0, 0.04))
    client.add_convex(
        "hull", np.random.default_rng(1).normal(size=(20, 3)) * 0.03, position=(0, -0.13, 0.04)
    )
    # a mesh the server renders as a sphere, within its error bound (the panel shows it)
    pebble = trimesh.creation.icosphere(subdivisions=4, radius=0.025)
    client.add_mesh("pebble", pebble, position=(-0.02, 0.07, 0.025))
    torus = trimesh.creation.torus(0.04, 0.015, major_sections=32, minor_sections=16)
    client.add_mesh("torus", torus, representation="mesh", position=(-0.12, 0.13, 0.015))
    # lying along x, spinning about the vertical through its centre (it stays in view)
    client.add_capsule(
        "spinner",
        0.02,
        0.04,
        position=(0.02, 0.24, 0.02),
        rotation=(0.7071067811865476, 0, 0.7071067811865476, 0),
        kinematic=True,
        angular_velocity=(0, 0, 0.5),
    )


class StrokingDevice:
    """A simulated impedance device held where the test says: a thread sends its state
    at RATE_HZ over the session's UDP channel, moving towards target by STEP_M a state."""

    def __init__(self, client):
        self.target = np.array(HOVER, dtype=float)
        self._position = self.target.copy()
        info = client.open_session("impedance", rate_hz=RATE_HZ, start=HOVER, max_force=10)
        self.session_id = info.session_id
        self._session = hapticd.DeviceSession(info)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self):
        period = 1 / RATE_HZ
        next_t = time.monotonic()
        while not self._stop.is_set():
            self._position += np.clip(self.target - self._position, -STEP_M, STEP_M)
            self._session.exchange(self._position, timeout_s=period)
            next_t += period
            time.sleep(max(0.0, next_t - time.monotonic()))

    def close(self):
        self._stop.set()
        self._thread.join()
        self._session.close()


def pixels(png):
    """(hue degrees, saturation, value) of every pixel."""
    rgb = np.asarray(Image.open(io.BytesIO(png)).convert("RGB"), dtype=np.float64) / 255
    hsv = rgb_to_hsv(rgb)
    hsv[..., 0] *= 360
    return hsv


def scene_pixels(browser):
    """The pixels of the 3D scene only: left of the panel (whose legend and table show
    every colour) and without the axes gizmo in the bottom left corner (red, green,
    blue), the rest greyed out."""
    png = browser.screenshot()
    panel_left = browser.evaluate(
        f"document.getElementById('{LEGEND_ID}').getBoundingClientRect().left"
    )
    hsv = pixels(png)
    hsv[:, max(0, int(panel_left) - PANEL_MARGIN_PX) :, 1] = 0
    hsv[-GIZMO_PX:, :GIZMO_PX, 1] = 0
    return hsv, png


def mask(hsv, colour):
    low, high = HUES[colour]
    return (hsv[..., 0] >= low) & (hsv[..., 0] <= high) & (hsv[..., 1] > 0.5) & (hsv[..., 2] > 0.3)


def count(hsv, colour):
    return int(mask(hsv, colour).sum())


def centroid(hsv, colour):
    rows, cols = np.nonzero(mask(hsv, colour))
    return np.array([cols.mean(), rows.mean()])


def session_line(text, session_id):
    """The panel's paragraph of one session, or ""."""
    match = re.search(rf"session {session_id:08x}: [^\n]*\n[^\n]*\n[^\n]*", text)
    return match.group(0) if match else ""


def shows_device_at(text, session_id, position, contact):
    line = session_line(text, session_id)
    where = "device (" + ", ".join(f"{c:+.4f}" for c in position) + ") m"
    state = "in contact" if contact else "free"
    return where in line and f", {state}," in line


@pytest.fixture
def view_page(bin_dir):
    """(client, device, browser, view process) over a server with the test scene."""
    assert chromium_path(), "chromium is not installed: bash deploy/install.sh"
    with (
        running_server(bin_dir, "--log-level", "warning") as server,
        hapticd.connect(server.tcp, timeout_s=20) as client,
    ):
        build_scene(client)
        view = subprocess.Popen(
            [sys.executable, "-m", "hapticd", "view", "--server", server.tcp, "--port", "0"],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        browser = None
        device = None
        try:
            url = json.loads(view.stdout.readline())["url"]
            device = StrokingDevice(client)
            browser = Browser()
            browser.navigate(url)
            yield client, device, browser, view
        finally:
            if browser is not None:
                browser.close()
            if device is not None:
                device.close()
            view.terminate()
            out, err = view.communicate(timeout=30)
        # SIGTERM is an interrupt to the command: it stops, printing what it did
        assert view.returncode == 0, err
        summary = json.loads(out.strip().splitlines()[-1])
        assert summary["stopped"] == "interrupted" and summary["samples"] > 0


def dismiss_notifications(browser):
    """Closes viser's notices (software WebGL) so they cover nothing."""
    browser.evaluate(
        "document.querySelectorAll('.mantine-Notification-closeButton,"
        " button[class*=\"Notification\"]').forEach(b => b.click())"
    )


def screenshot_when(browser, condition):
    """The scene pixels of the first screenshot for which condition holds, polled; None
    if none within PAGE_TIMEOUT_S."""

    def take():
        hsv, _ = scene_pixels(browser)
        return hsv if condition(hsv) else None

    return wait_for(take, PAGE_TIMEOUT_S, interval_s=0.5)


def counts(browser):
    """Each colour's pixels now (for a failure's message)."""
    hsv, _ = scene_pixels(browser)
    return {colour: count(hsv, colour) for colour in HUES}


def test_the_page_shows_the_scene_the_avatar_and_the_force(view_page):
    _, device, browser, _ = view_page
    session = device.session_id

    # every representation in its colour, the avatar free above the crate, no force
    assert wait_for(lambda: "spinner (kinematic)" in browser.text(), PAGE_TIMEOUT_S), browser.text()
    assert wait_for(lambda: shows_device_at(browser.text(), session, HOVER, False), PAGE_TIMEOUT_S)
    dismiss_notifications(browser)
    free = screenshot_when(
        browser,
        lambda hsv: all(
            count(hsv, c) >= PRESENT_PIXELS
            for c in ("sphere", "box", "capsule", "convex", "mesh", "avatar")
        )
        and count(hsv, "force") <= ABSENT_PIXELS,
    )
    assert free is not None, counts(browser)
    hovering = centroid(free, "avatar")
    spinner_before = mask(free, "capsule")

    # pressed into the top: the panel says contact and about 5 N; the arrow appears
    device.target[:] = PRESSED
    assert wait_for(
        lambda: shows_device_at(browser.text(), session, PRESSED, True), PAGE_TIMEOUT_S
    ), browser.text()
    force = float(re.search(r"\|F\| = ([0-9.]+) N", session_line(browser.text(), session))[1])
    assert 3.0 < force < 7.0, browser.text()  # 1000 N/m x 5 mm, within the god object's
    pressed = screenshot_when(browser, lambda hsv: count(hsv, "force") >= PRESENT_PIXELS)
    assert pressed is not None, counts(browser)
    # the avatar stays on the surface as the device goes in: it moved down, not into the box
    assert np.linalg.norm(centroid(pressed, "avatar") - hovering) > 3

    # stroked along the top: the avatar moves with the device, the arrow with it
    device.target[:] = STROKED
    assert wait_for(
        lambda: shows_device_at(browser.text(), session, STROKED, True), PAGE_TIMEOUT_S
    ), browser.text()
    start = centroid(pressed, "avatar")
    stroked = screenshot_when(
        browser,
        lambda hsv: count(hsv, "force") >= PRESENT_PIXELS
        and count(hsv, "avatar") >= PRESENT_PIXELS
        and np.linalg.norm(centroid(hsv, "avatar") - start) > 20,
    )
    assert stroked is not None, counts(browser)
    # the force arrow starts at the avatar: their blobs touch
    assert np.linalg.norm(centroid(stroked, "force") - centroid(stroked, "avatar")) < 80
    if os.environ.get("HAPTICD_VIEW_SCREENSHOT"):
        # a palette of 256 colours keeps the PNG small
        image = Image.open(io.BytesIO(browser.screenshot())).convert("RGB").quantize(256)
        image.save(os.environ["HAPTICD_VIEW_SCREENSHOT"], optimize=True)

    # lifted off: the arrow goes
    device.target[:] = LIFTED
    assert wait_for(lambda: shows_device_at(browser.text(), session, LIFTED, False), PAGE_TIMEOUT_S)
    lifted = screenshot_when(browser, lambda hsv: count(hsv, "force") <= ABSENT_PIXELS)
    assert lifted is not None, counts(browser)

    # the kinematic spinner turns on the page: its pixels are not where they were
    def turned(hsv):
        now = mask(hsv, "capsule")
        return (now ^ spinner_before).sum() > 0.3 * max(1, spinner_before.sum())

    assert screenshot_when(browser, turned) is not None, counts(browser)


def test_an_edit_appears_on_the_page(view_page):
    client, _, browser, _ = view_page
    assert wait_for(lambda: "crate" in browser.text(), PAGE_TIMEOUT_S)
    dismiss_notifications(browser)
    before = screenshot_when(browser, lambda hsv: count(hsv, "box") >= PRESENT_PIXELS)
    assert before is not None, counts(browser)
    client.remove_object("crate")
    gone = screenshot_when(browser, lambda hsv: count(hsv, "box") <= ABSENT_PIXELS)
    assert gone is not None, counts(browser)
    assert "crate" not in browser.text()
    client.add_sphere("late", 0.05, position=(0.1, 0, 0.05))
    assert wait_for(lambda: "late" in browser.text(), PAGE_TIMEOUT_S)
    blue_before = count(before, "sphere")
    more_blue = screenshot_when(
        browser, lambda hsv: count(hsv, "sphere") > blue_before + PRESENT_PIXELS
    )
    assert more_blue is not None, counts(browser)
