"""What the browser view draws, decided without a browser or a server (hapticd.view
applies it to viser): each object as the server represents it, as a mesh or a viser
primitive in one colour per representation, and each session's device point, avatar,
the spring between them and the force as an arrow scaled in metres per newton.

Units SI; everything in the world frame W; quaternions (w, x, y, z), as viser's are.
"""

from __future__ import annotations

import html
from dataclasses import dataclass, field

import numpy as np
import trimesh
from numpy.typing import NDArray
from scipy.spatial import ConvexHull

from hapticd._validate import FloatArray
from hapticd.objects import Box, Capsule, Convex, Mesh, Plane, Sphere
from hapticd.results import ObjectInfo, SceneInfo, SessionTelemetry

# One colour (RGB) per representation, far apart in hue so that a screenshot tells them
# apart under the page's lighting, and none near the session colours below.
REPRESENTATION_COLOURS: dict[str, tuple[int, int, int]] = {
    "sphere": (30, 100, 255),  # blue
    "box": (255, 130, 0),  # orange
    "capsule": (20, 190, 60),  # green
    "convex": (140, 60, 230),  # violet
    "mesh": (0, 190, 200),  # teal
    "plane": (190, 190, 190),  # grey, see-through
}
PLANE_OPACITY = 0.5
AVATAR_COLOUR = (255, 230, 0)  # yellow
DEVICE_COLOUR = (250, 250, 250)  # white
FORCE_COLOUR = (255, 0, 190)  # magenta
SPRING_COLOUR = (90, 90, 90)
AVATAR_RADIUS_M = 0.007
DEVICE_RADIUS_M = 0.004
# A plane is drawn as a square this many times the finite objects' extent (at least 1 m).
PLANE_EXTENT_FACTOR = 3.0
MIN_PLANE_SIZE_M = 1.0
# Forces below this are not drawn (N): an arrow of no length has no direction.
MIN_DRAWN_FORCE_N = 1e-6
# Sessions that ended are not drawn.
ENDED_STATES = ("closed", "timed_out")


@dataclass(frozen=True, eq=False)
class ObjectDrawing:
    """One object as drawn: kind "sphere" (radius), "box" (dimensions, full lengths) or
    "mesh" (vertices, faces, in the object's frame); its colour, opacity and pose."""

    kind: str
    colour: tuple[int, int, int]
    position: FloatArray
    wxyz: FloatArray
    radius: float = 0.0
    dimensions: FloatArray = field(default_factory=lambda: np.zeros(3))
    vertices: FloatArray = field(default_factory=lambda: np.zeros((0, 3)))
    faces: NDArray[np.uint32] = field(default_factory=lambda: np.zeros((0, 3), np.uint32))
    opacity: float = 1.0
    double_sided: bool = False

    def same_geometry(self, other: ObjectDrawing) -> bool:
        """Whether other draws the same shape (poses aside): then the node is moved,
        not rebuilt."""
        return (
            self.kind == other.kind
            and self.colour == other.colour
            and self.radius == other.radius
            and self.opacity == other.opacity
            and np.array_equal(self.dimensions, other.dimensions)
            and np.array_equal(self.vertices, other.vertices)
            and np.array_equal(self.faces, other.faces)
        )


def capsule_mesh(radius: float, half_length: float) -> tuple[FloatArray, NDArray[np.uint32]]:
    """A capsule along z (radius, segment from -half_length to +half_length)."""
    capsule = trimesh.creation.capsule(height=2 * half_length, radius=radius, count=[24, 24])
    return np.asarray(capsule.vertices), np.asarray(capsule.faces, dtype=np.uint32)


def hull_mesh(points: FloatArray) -> tuple[FloatArray, NDArray[np.uint32]]:
    """The triangles of the hull of points (a solid hull, as the server keeps; their
    winding is not fixed: drawn double-sided)."""
    hull = ConvexHull(points)
    return np.asarray(points), np.asarray(hull.simplices, dtype=np.uint32)


def plane_mesh(size: float) -> tuple[FloatArray, NDArray[np.uint32]]:
    """A square of side size (m) in the xy plane, centred on the origin."""
    h = size / 2
    vertices = np.array([[-h, -h, 0], [h, -h, 0], [h, h, 0], [-h, h, 0]], dtype=np.float64)
    return vertices, np.array([[0, 1, 2], [0, 2, 3]], dtype=np.uint32)


def plane_size(scene: SceneInfo) -> float:
    """The side (m) of the square a plane is drawn as: PLANE_EXTENT_FACTOR times the
    extent of the scene's finite bounds, at least MIN_PLANE_SIZE_M."""
    finite = [
        (info.bounds_min, info.bounds_max)
        for info in scene.objects
        if np.all(np.isfinite(info.bounds_min)) and np.all(np.isfinite(info.bounds_max))
    ]
    if not finite:
        return MIN_PLANE_SIZE_M
    low = np.min([b[0] for b in finite], axis=0)
    high = np.max([b[1] for b in finite], axis=0)
    return max(MIN_PLANE_SIZE_M, PLANE_EXTENT_FACTOR * float(np.max(high - low)))


def object_drawing(info: ObjectInfo, plane_side_m: float) -> ObjectDrawing | None:
    """How info is drawn, as the server represents it; None for an object kept as a
    mesh whose vertices and triangles have not been read."""
    shape = info.represented
    colour = REPRESENTATION_COLOURS.get(info.representation, REPRESENTATION_COLOURS["mesh"])
    p, q = info.pose.position, info.pose.orientation
    if isinstance(shape, Sphere):
        return ObjectDrawing("sphere", colour, radius=shape.radius, position=p, wxyz=q)
    if isinstance(shape, Box):
        return ObjectDrawing("box", colour, dimensions=2 * shape.half_extents, position=p, wxyz=q)
    if isinstance(shape, Capsule):
        vertices, faces = capsule_mesh(shape.radius, shape.half_length)
        return ObjectDrawing("mesh", colour, vertices=vertices, faces=faces, position=p, wxyz=q)
    if isinstance(shape, Convex):
        vertices, faces = hull_mesh(shape.points)
        return ObjectDrawing(
            "mesh", colour, vertices=vertices, faces=faces, double_sided=True, position=p, wxyz=q
        )
    if isinstance(shape, Plane):
        vertices, faces = plane_mesh(plane_side_m)
        return ObjectDrawing(
            "mesh",
            REPRESENTATION_COLOURS["plane"],
            vertices=vertices,
            faces=faces,
            opacity=PLANE_OPACITY,
            double_sided=True,
            position=p,
            wxyz=q,
        )
    if isinstance(shape, Mesh):
        # an open mesh is a surface: seen from either side
        return ObjectDrawing(
            "mesh",
            colour,
            vertices=shape.vertices,
            faces=shape.triangles,
            double_sided=not info.closed,
            position=p,
            wxyz=q,
        )
    return None


def meshes_to_read(scene: SceneInfo, held: dict[str, int]) -> list[str]:
    """The objects kept as meshes whose vertices and triangles must be read: those with
    no data in scene and none held (held: name -> shape digest of the data held)."""
    return [
        info.name
        for info in scene.objects
        if info.representation == "mesh"
        and info.represented is None
        and held.get(info.name) != info.shape_digest
    ]


@dataclass(frozen=True, eq=False)
class SessionDrawing:
    """One session as drawn: the device point, the avatar (proxy), and the force arrow
    from the avatar (None when the force is below MIN_DRAWN_FORCE_N), whose length is
    |force| times the scale (m/N)."""

    session_id: int
    device: FloatArray
    avatar: FloatArray
    force_arrow: FloatArray | None  # (2, 3): start, end


def session_drawing(sample: SessionTelemetry, scale_m_per_n: float) -> SessionDrawing | None:
    """How a session's sample is drawn; None for a session that ended."""
    if sample.state in ENDED_STATES:
        return None
    arrow = None
    if float(np.linalg.norm(sample.force)) >= MIN_DRAWN_FORCE_N:
        arrow = np.array([sample.avatar, sample.avatar + scale_m_per_n * sample.force])
    return SessionDrawing(sample.session_id, sample.device_position, sample.avatar, arrow)


def _metres(value: float) -> str:
    return "no bound" if not np.isfinite(value) else f"{value:.3g} m"


def objects_table_html(scene: SceneInfo) -> str:
    """The objects panel: each object's name, the shape it was given as, the
    representation it is rendered as (with its colour) and that representation's error
    bound."""
    rows = []
    for info in scene.objects:
        r, g, b = REPRESENTATION_COLOURS.get(info.representation, REPRESENTATION_COLOURS["mesh"])
        swatch = f'<span style="color:rgb({r},{g},{b})">&#9632;</span>'
        moving = " (kinematic)" if info.kinematic else ""
        rows.append(
            f"<tr><td>{html.escape(info.name)}{moving}</td><td>{info.shape}</td>"
            f"<td>{swatch} {info.representation}</td>"
            f"<td>{_metres(info.representation_error)}</td></tr>"
        )
    return (
        f"<p>scene version {scene.version}, tolerance {scene.tolerance:.3g} m</p>"
        '<table style="font-size:0.8em"><tr><th>object</th><th>given as</th>'
        "<th>rendered as</th><th>error</th></tr>" + "".join(rows) + "</table>"
    )


def _vector(v: FloatArray) -> str:
    return "(" + ", ".join(f"{c:+.4f}" for c in v) + ")"


def sessions_html(samples: list[SessionTelemetry], scale_m_per_n: float) -> str:
    """The sessions panel: per session its state, whether in contact, the force (N),
    the device's and the avatar's positions (m)."""
    if not samples:
        return "<p>no sessions</p>"
    rows = []
    for s in samples:
        contact = "in contact" if s.contact else "free"
        rows.append(
            f"<p>session {s.session_id:08x}: {s.state}, {contact}, "
            f"|F| = {float(np.linalg.norm(s.force)):.3f} N<br>"
            f"device {_vector(s.device_position)} m<br>avatar {_vector(s.avatar)} m</p>"
        )
    return f"<p>force arrows: {scale_m_per_n:g} m per N</p>" + "".join(rows)


def legend_html() -> str:
    """The colours: one per representation, and the sessions'."""
    items = [(name, colour) for name, colour in REPRESENTATION_COLOURS.items()] + [
        ("avatar", AVATAR_COLOUR),
        ("device", DEVICE_COLOUR),
        ("force", FORCE_COLOUR),
    ]
    swatches = " ".join(
        f'<span style="color:rgb({r},{g},{b})">&#9632;</span> {name}' for name, (r, g, b) in items
    )
    return f'<div id="{LEGEND_ID}">{swatches}</div>'


# The legend's element id: where the panel is on the page (tests look left of it).
LEGEND_ID = "hapticd-legend"
