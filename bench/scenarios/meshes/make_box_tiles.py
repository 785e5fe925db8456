#!/usr/bin/env python3
"""Writes box_tiles.obj: a closed, outward-wound box (80 x 80 x 40 mm, centred on its
origin) whose every face is tiled 8 x 8 (386 vertices, 768 triangles), for
box_edge_mesh.json. Tiled on purpose: a local model cuts a mesh as the patch of its
triangles near the avatar, and a box of 12 triangles would always be cut whole.

    python3 make_box_tiles.py [--half 0.04 0.04 0.02] [--tiles 8] [--out box_tiles.obj]
"""

import argparse
from pathlib import Path


def box_tiles(half, tiles):
    """The vertices and outward-wound triangles of the tiled box."""
    vertices, index, triangles = [], {}, []

    def vertex(p):
        key = tuple(round(c, 9) for c in p)
        if key not in index:
            index[key] = len(vertices)
            vertices.append(key)
        return index[key]

    for axis in range(3):
        for sign in (-1, 1):
            # (u, v, axis) cyclic, so u x v is +axis; swapped on the negative face
            u, v = (axis + 1) % 3, (axis + 2) % 3
            if sign < 0:
                u, v = v, u

            def corner(i, j, axis=axis, sign=sign, u=u, v=v):
                p = [0.0, 0.0, 0.0]
                p[axis] = sign * half[axis]
                p[u] = -half[u] + 2 * half[u] * i / tiles
                p[v] = -half[v] + 2 * half[v] * j / tiles
                return vertex(p)

            for i in range(tiles):
                for j in range(tiles):
                    a, b, c, d = corner(i, j), corner(i + 1, j), corner(i + 1, j + 1), corner(i, j + 1)
                    triangles += [(a, b, c), (a, c, d)]
    return vertices, triangles


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--half", type=float, nargs=3, default=(0.04, 0.04, 0.02))
    parser.add_argument("--tiles", type=int, default=8)
    parser.add_argument("--out", default=str(Path(__file__).with_name("box_tiles.obj")))
    args = parser.parse_args()
    vertices, triangles = box_tiles(args.half, args.tiles)
    lines = [f"# make_box_tiles.py --half {' '.join(f'{h:g}' for h in args.half)} --tiles {args.tiles}"]
    lines += [f"v {x:.9g} {y:.9g} {z:.9g}" for x, y, z in vertices]
    lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in triangles]
    Path(args.out).write_text("\n".join(lines) + "\n")
    print(f"{args.out}: {len(vertices)} vertices, {len(triangles)} triangles")


if __name__ == "__main__":
    main()
