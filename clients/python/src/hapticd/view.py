"""The live view in the browser: the scene as the server represents it and every
session's device, avatar and force, served on loopback by viser.

    with hapticd.connect("127.0.0.1:7460") as client:
        view = hapticd.view.serve(client, port=8080)   # open view.url
        ...
        view.stop()

or `python -m hapticd view --server HOST:PORT [--port N]`.

Why viser (PyPI `viser`, 1.1): its wheel carries its own built web client (three.js,
React), so the page works with no npm, no CDN and no network beyond loopback, which is
all a hapticd machine may have; its Python API is a scene tree of meshes, primitives and
arrows addressed by name, posed with (w, x, y, z) quaternions like hapticd's, updated
from any thread and pushed to every open page over one websocket; and it has GUI
panels. It has no access control, so the page is served on 127.0.0.1 only (reach it
from elsewhere through an SSH tunnel).

Theory of operation. One thread per view:

    Subscribe(rate_hz) --> sample --+--> scene_version changed? --> GetScene
                                    |        (the mesh data of the meshes not held,
                                    |         by name, read once per shape digest)
                                    |        --> objects drawn / moved / removed
                                    +--> sessions drawn: device, avatar, force arrow

It asks the server for nothing but one telemetry subscription at rate_hz (at most 60
Hz: the 1 kHz loop is never asked for more than telemetry gives) and a GetScene each
time the scene's version moves on, so an edit shows at the next sample, and a kinematic
object moving publishes a version a millisecond and so is redrawn every sample.
"""

from __future__ import annotations

import contextlib
import dataclasses
import sys
import threading
import urllib.parse
from dataclasses import dataclass

import numpy as np
import viser
from numpy.typing import ArrayLike

from hapticd import _validate as check
from hapticd import _view_model as model
from hapticd.client import Client, Subscription
from hapticd.errors import HapticdError, LocalError, RemoteError, Timeout
from hapticd.objects import Mesh
from hapticd.results import SceneInfo, SessionTelemetry, Telemetry

# The telemetry rates a view may ask for (Hz): a page redraws at 30-60 frames a second.
RATE_RANGE = check.Range(1, 60, "Hz")
# Force arrows: the longest drawn is this many metres per newton at most (and > 0).
FORCE_SCALE_RANGE = check.Range(0, 1, "m/N", low_open=True)
DEFAULT_RATE_HZ = 30.0
DEFAULT_FORCE_SCALE_M_PER_N = 0.01
HOST = "127.0.0.1"
# How long (s) the view waits for a sample before giving up on the server.
SAMPLE_TIMEOUT_S = 10.0
# How soon (s) the view's thread notices stop().
STOP_POLL_S = 0.25
# Refusals of a mesh-data read that leave the mesh undrawn rather than stop the view: too
# large for one reply, or removed since the scene was read.
UNREADABLE = ("RESOURCE_EXHAUSTED", "FRAME_TOO_LARGE", "NOT_FOUND")


@dataclass
class ViewCounters:
    """What a view has done: samples drawn, scene reads, mesh data reads."""

    samples: int = 0
    scene_reads: int = 0
    mesh_reads: int = 0


def _node_name(kind: str, name: str) -> str:
    """A viser node name for an object or session name ("/" would nest nodes)."""
    return f"/{kind}/{urllib.parse.quote(name, safe='')}"


class View:
    """A running view (made by serve): url of the page, counters, error (the exception
    that stopped it, or None), stop() and wait(). A context manager that stops it."""

    def __init__(
        self,
        client: Client,
        *,
        port: int,
        rate_hz: float,
        force_scale_m_per_n: float,
        camera: tuple[ArrayLike, ArrayLike] | None,
    ) -> None:
        self._client = client
        self.rate_hz = rate_hz
        self.force_scale_m_per_n = force_scale_m_per_n
        self._camera = camera
        self.counters = ViewCounters()
        self.error: HapticdError | None = None
        self._stop = threading.Event()
        # viser prints a banner and a goodbye on stdout: the command line's stdout is JSON
        with contextlib.redirect_stdout(sys.stderr):
            self._server = viser.ViserServer(host=HOST, port=port, verbose=False)
        self.port = self._server.get_port()
        self.url = f"http://{HOST}:{self.port}/"
        self._server.scene.set_up_direction("+z")
        self._server.gui.add_html(model.legend_html())
        self._status = self._server.gui.add_html("<p>connecting</p>")
        with self._server.gui.add_folder("Sessions"):
            self._sessions_panel = self._server.gui.add_html("<p>no sessions</p>")
        with self._server.gui.add_folder("Objects"):
            self._objects_panel = self._server.gui.add_html("<p>reading the scene</p>")
        # what is drawn: object name -> drawing and node; mesh data held (by digest)
        self._objects: dict[str, tuple[model.ObjectDrawing, viser.SceneNodeHandle]] = {}
        self._meshes: dict[str, tuple[int, Mesh]] = {}
        self._unreadable: dict[str, int] = {}
        self._sessions: dict[int, dict[str, viser.SceneNodeHandle]] = {}
        self._scene_version: int | None = None
        try:
            self._subscription: Subscription = client.subscribe(rate_hz)
        except BaseException:
            with contextlib.redirect_stdout(sys.stderr):
                self._server.stop()
            raise
        self._thread = threading.Thread(target=self._run, name="hapticd-view", daemon=True)
        self._thread.start()

    def __enter__(self) -> View:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.stop()

    @property
    def running(self) -> bool:
        """Whether the view still follows the server."""
        return self._thread.is_alive()

    def wait(self, timeout_s: float | None = None) -> bool:
        """Waits until the view stops (stop(), or the server failed: see error), at most
        timeout_s; whether it has stopped."""
        self._thread.join(timeout_s)
        return not self._thread.is_alive()

    def stop(self) -> None:
        """Stops following the server (unsubscribes) and closes the page's server.
        Idempotent."""
        self._stop.set()
        self._thread.join()
        with contextlib.redirect_stdout(sys.stderr):
            self._server.stop()

    # ---- the view's thread ----

    def _run(self) -> None:
        try:
            with self._subscription:
                silent_s = 0.0
                # wait for samples in short slices, so that stop() is heard within one
                while not self._stop.is_set():
                    try:
                        sample = self._subscription.next(STOP_POLL_S)
                    except Timeout:
                        silent_s += STOP_POLL_S
                        if silent_s >= SAMPLE_TIMEOUT_S:
                            raise
                        continue
                    silent_s = 0.0
                    self._draw(sample)
        except HapticdError as exc:
            self.error = exc
            self._status.content = f"<p>stopped: {type(exc).__name__}: {exc}</p>"

    def _draw(self, sample: Telemetry) -> None:
        if sample.scene_version != self._scene_version:
            self._draw_scene()
        self._draw_sessions(sample.sessions)
        self.counters.samples += 1
        self._status.content = (
            f"<p>following {self._client.server_name} at {self.rate_hz:g} Hz "
            f"(scene version {self._scene_version})</p>"
        )

    def _draw_scene(self) -> None:
        """Reads the scene (and the mesh data not held) and redraws what changed."""
        scene = self._client.scene()
        self.counters.scene_reads += 1
        self._read_meshes(scene)
        if self._scene_version is None:
            self._place_camera(scene)
        self._scene_version = scene.version
        side = model.plane_size(scene)
        drawn = set()
        for info in scene.objects:
            held = self._meshes.get(info.name)
            if info.represented is None and held is not None and held[0] == info.shape_digest:
                info = dataclasses.replace(info, represented=held[1])
            drawing = model.object_drawing(info, side)
            if drawing is not None:
                drawn.add(info.name)
                self._draw_object(info.name, drawing)
        for name in set(self._objects) - drawn:
            self._objects.pop(name)[1].remove()
        names = {info.name for info in scene.objects}
        for name in set(self._meshes) - names:
            del self._meshes[name]
        self._objects_panel.content = model.objects_table_html(scene)

    def _read_meshes(self, scene: SceneInfo) -> None:
        """Reads the vertices and triangles of the meshes in scene that the view does
        not hold: all in one request, else (too large for one reply) one at a time. A
        mesh too large even alone, or gone meanwhile, stays undrawn (and one too large
        is not asked for again until its shape changes)."""
        held = {name: digest for name, (digest, _) in self._meshes.items()}
        names = [
            name
            for name in model.meshes_to_read(scene, held)
            if self._unreadable.get(name) != scene.object(name).shape_digest
        ]
        if not names:
            return
        try:
            self._read_mesh_data(names)
            return
        except RemoteError as exc:
            if exc.code not in UNREADABLE or len(names) == 1:
                if exc.code not in UNREADABLE:
                    raise
                self._unreadable[names[0]] = scene.object(names[0]).shape_digest
                return
        for name in names:
            try:
                self._read_mesh_data([name])
            except RemoteError as exc:
                if exc.code not in UNREADABLE:
                    raise
                self._unreadable[name] = scene.object(name).shape_digest

    def _read_mesh_data(self, names: list[str]) -> None:
        """Holds the mesh data of the objects named, read in one request."""
        read = self._client.scene(mesh_data_for=names)
        self.counters.mesh_reads += 1
        for info in read.objects:
            if info.name in names and isinstance(info.represented, Mesh):
                self._meshes[info.name] = (info.shape_digest, info.represented)

    def _draw_object(self, name: str, drawing: model.ObjectDrawing) -> None:
        """Moves the object's node, or (a new or changed shape) builds it anew."""
        held = self._objects.get(name)
        if held is not None and held[0].same_geometry(drawing):
            node = held[1]
            node.position = drawing.position
            node.wxyz = drawing.wxyz
            self._objects[name] = (drawing, node)
            return
        if held is not None:
            held[1].remove()
        scene = self._server.scene
        node_name = _node_name("objects", name)
        position, wxyz = drawing.position, drawing.wxyz
        built: viser.SceneNodeHandle
        if drawing.kind == "sphere":
            built = scene.add_icosphere(
                node_name,
                radius=drawing.radius,
                color=drawing.colour,
                subdivisions=4,
                position=position,
                wxyz=wxyz,
            )
        elif drawing.kind == "box":
            d = drawing.dimensions
            built = scene.add_box(
                node_name,
                dimensions=(float(d[0]), float(d[1]), float(d[2])),
                color=drawing.colour,
                position=position,
                wxyz=wxyz,
            )
        else:
            built = scene.add_mesh_simple(
                node_name,
                vertices=drawing.vertices,
                faces=drawing.faces,
                color=drawing.colour,
                opacity=None if drawing.opacity >= 1 else drawing.opacity,
                side="double" if drawing.double_sided else "front",
                position=position,
                wxyz=wxyz,
            )
        self._objects[name] = (drawing, built)

    def _place_camera(self, scene: SceneInfo) -> None:
        """Where a page's camera starts: the caller's, else looking at the finite
        objects' bounds from above and to the side."""
        if self._camera is not None:
            position = check.vector3(self._camera[0], "camera[0]")
            look_at = check.vector3(self._camera[1], "camera[1]")
        else:
            finite = [
                (info.bounds_min, info.bounds_max)
                for info in scene.objects
                if np.all(np.isfinite(info.bounds_min)) and np.all(np.isfinite(info.bounds_max))
            ]
            if finite:
                low = np.min([b[0] for b in finite], axis=0)
                high = np.max([b[1] for b in finite], axis=0)
            else:
                low, high = np.full(3, -0.25), np.full(3, 0.25)
            look_at = (low + high) / 2
            reach = max(0.2, float(np.max(high - low)))
            position = look_at + reach * np.array([0.42, -0.8, 0.55])
        self._server.initial_camera.position = position
        self._server.initial_camera.look_at = look_at

    def _draw_sessions(self, samples: list[SessionTelemetry]) -> None:
        """Each session's device point, avatar, spring and force arrow."""
        scene = self._server.scene
        drawn = set()
        for sample in samples:
            drawing = model.session_drawing(sample, self.force_scale_m_per_n)
            if drawing is None:
                continue
            drawn.add(drawing.session_id)
            nodes = self._sessions.get(drawing.session_id)
            base = _node_name("sessions", f"{drawing.session_id:08x}")
            if nodes is None:
                nodes = {
                    "device": scene.add_icosphere(
                        f"{base}/device", radius=model.DEVICE_RADIUS_M, color=model.DEVICE_COLOUR
                    ),
                    "avatar": scene.add_icosphere(
                        f"{base}/avatar", radius=model.AVATAR_RADIUS_M, color=model.AVATAR_COLOUR
                    ),
                }
                self._sessions[drawing.session_id] = nodes
            nodes["device"].position = drawing.device
            nodes["avatar"].position = drawing.avatar
            self._draw_line(nodes, "spring", f"{base}/spring", drawing)
            self._draw_arrow(nodes, f"{base}/force", drawing)
        for session_id in set(self._sessions) - drawn:
            for node in self._sessions.pop(session_id).values():
                node.remove()
        self._sessions_panel.content = model.sessions_html(
            [s for s in samples if s.state not in model.ENDED_STATES], self.force_scale_m_per_n
        )

    def _draw_line(
        self,
        nodes: dict[str, viser.SceneNodeHandle],
        key: str,
        name: str,
        drawing: model.SessionDrawing,
    ) -> None:
        points = np.array([[drawing.avatar, drawing.device]], dtype=np.float32)
        node = nodes.get(key)
        if node is None:
            nodes[key] = self._server.scene.add_line_segments(
                name, points, model.SPRING_COLOUR, thickness=0.001
            )
        else:
            node.points = points  # type: ignore[attr-defined]

    def _draw_arrow(
        self, nodes: dict[str, viser.SceneNodeHandle], name: str, drawing: model.SessionDrawing
    ) -> None:
        arrow = drawing.force_arrow
        node = nodes.get("force")
        if arrow is None:
            if node is not None:
                node.visible = False
            return
        points = np.array([arrow], dtype=np.float32)
        if node is None:
            nodes["force"] = self._server.scene.add_arrows(
                name,
                points,
                model.FORCE_COLOUR,
                shaft_radius=0.002,
                head_radius=0.005,
                head_length=0.01,
            )
            return
        node.points = points  # type: ignore[attr-defined]
        node.visible = True


def serve(
    client: Client,
    *,
    port: int = 8080,
    rate_hz: float = DEFAULT_RATE_HZ,
    force_scale_m_per_n: float = DEFAULT_FORCE_SCALE_M_PER_N,
    camera: tuple[ArrayLike, ArrayLike] | None = None,
) -> View:
    """Serves the live view of client's server on http://127.0.0.1:port/ (port 0: any
    free one; a port in use: viser takes the next free one; View.url says which) and
    returns the running View. rate_hz: the telemetry rate the view follows sessions at
    (in [1, 60] Hz); force_scale_m_per_n: an arrow's length per newton of force (in
    (0, 1] m/N); camera: (position, look_at) in W where a page's camera starts (default:
    looking at the scene's finite objects). The client may be used by other threads
    meanwhile; stop the View before closing the client. LocalError names a bad
    argument."""
    if not isinstance(client, Client):
        raise LocalError(f"client is {client!r}; it must be a hapticd Client (hapticd.connect)")
    if isinstance(port, bool) or not isinstance(port, int) or not 0 <= port <= 65535:
        raise LocalError(f"port is {port!r}; it must be an integer in [0, 65535]")
    rate = check.number(rate_hz, "rate_hz")
    if rate not in RATE_RANGE:
        raise LocalError(f"rate_hz is {rate!r}; it must be in {RATE_RANGE}")
    scale = check.number(force_scale_m_per_n, "force_scale_m_per_n")
    if scale not in FORCE_SCALE_RANGE:
        raise LocalError(f"force_scale_m_per_n is {scale!r}; it must be in {FORCE_SCALE_RANGE}")
    if camera is not None:
        if not isinstance(camera, tuple) or len(camera) != 2:
            raise LocalError(f"camera is {camera!r}; it must be (position, look_at)")
        check.vector3(camera[0], "camera[0]")
        check.vector3(camera[1], "camera[1]")
    return View(client, port=port, rate_hz=rate, force_scale_m_per_n=scale, camera=camera)
