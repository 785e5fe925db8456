#!/usr/bin/env python3
"""Writes icosphere.obj: a closed, outward-wound icosphere (radius 0.05 m, two subdivisions:
162 vertices, 320 triangles) for the slide_sphere_mesh_* scenarios. Coarse on purpose, so
that its facets can be felt without force shading.

    python3 make_icosphere.py [--radius 0.05] [--subdivisions 2] [--out icosphere.obj]
"""

import argparse
import math
from pathlib import Path


def icosahedron():
    """The 12 vertices (on the unit sphere) and 20 outward-wound faces of an icosahedron."""
    t = (1 + math.sqrt(5)) / 2
    corners = [(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0),
               (0, -1, t), (0, 1, t), (0, -1, -t), (0, 1, -t),
               (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)]
    vertices = [normalized(c) for c in corners]
    faces = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11),
             (1, 5, 9), (5, 11, 4), (11, 10, 2), (10, 7, 6), (7, 1, 8),
             (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8), (3, 8, 9),
             (4, 9, 5), (2, 4, 11), (6, 2, 10), (8, 6, 7), (9, 8, 1)]
    return vertices, faces


def normalized(v):
    n = math.sqrt(sum(c * c for c in v))
    return tuple(c / n for c in v)


def subdivide(vertices, faces):
    """Splits every triangle into four, pushing the new edge midpoints onto the sphere."""
    midpoint_of = {}

    def midpoint(a, b):
        key = (min(a, b), max(a, b))
        if key not in midpoint_of:
            midpoint_of[key] = len(vertices)
            vertices.append(normalized(tuple((p + q) / 2 for p, q in zip(vertices[a], vertices[b], strict=True))))
        return midpoint_of[key]

    result = []
    for a, b, c in faces:
        ab, bc, ca = midpoint(a, b), midpoint(b, c), midpoint(c, a)
        result += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
    return result


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--radius", type=float, default=0.05)
    parser.add_argument("--subdivisions", type=int, default=2)
    parser.add_argument("--out", type=Path, default=Path(__file__).with_name("icosphere.obj"))
    args = parser.parse_args()

    vertices, faces = icosahedron()
    for _ in range(args.subdivisions):
        faces = subdivide(vertices, faces)
    lines = [f"# icosphere: radius {args.radius} m, {args.subdivisions} subdivisions, "
             f"{len(vertices)} vertices, {len(faces)} triangles (make_icosphere.py)"]
    lines += [f"v {x * args.radius:.17g} {y * args.radius:.17g} {z * args.radius:.17g}" for x, y, z in vertices]
    lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in faces]
    args.out.write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
