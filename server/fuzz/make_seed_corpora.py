#!/usr/bin/env python3
"""Writes the fuzz targets' seed corpora, one folder per target, from the project's own
inputs: the golden vectors, the conformance cases, the bench scenarios and their mesh,
the inputs of the unit tests, and seeds/control_requests.txt (framed by the
make_control_seeds program of the fuzz build). Nothing here is committed output: run it
into the build folder (deploy/fuzz.sh does).

usage: make_seed_corpora.py --out DIR --control-seeds PROGRAM
"""

import argparse
import codecs
import json
import math
import re
import struct
import subprocess
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
CONFORMANCE = Path("/work/shared/conformance/public")
LINES_PER_CONFORMANCE_FILE = 4


def write(folder: Path, name: str, data: bytes) -> None:
    folder.mkdir(parents=True, exist_ok=True)
    (folder / name).write_bytes(data)


def raw_strings(source: Path) -> list[str]:
    """The C++ raw string literals R"(...)" of a file, adjacent ones joined."""
    text = source.read_text()
    joined: list[str] = []
    last_end = None
    for match in re.finditer(r'R"\((.*?)\)"', text, re.S):
        if last_end is not None and text[last_end:match.start()].strip() == "":
            joined[-1] += match.group(1)
        else:
            joined.append(match.group(1))
        last_end = match.end()
    return joined


def call_literals(source: Path, function: str) -> list[str]:
    """The plain string literals passed first to function(...) in a file, unescaped."""
    pattern = re.escape(function) + r'\("((?:[^"\\]|\\.)*)"'
    return [codecs.decode(m.group(1), "unicode_escape") for m in re.finditer(pattern, source.read_text())]


def datagram_seeds(out: Path, golden: list[dict]) -> None:
    for vector in golden:
        if "datagram_hex" in vector:
            write(out, f"golden-{vector['name']}", bytes.fromhex(vector["datagram_hex"]))
            # the same message under a tag of zeros: parses, fails the tag check
            write(out, f"golden-{vector['name']}-zero-tag", bytes.fromhex(vector["hex"]) + bytes(16))


def control_seeds(out: Path, golden: list[dict], program: str) -> None:
    out.mkdir(parents=True, exist_ok=True)
    subprocess.run([program, str(REPO / "server/fuzz/seeds/control_requests.txt"), str(out)], check=True)
    for vector in golden:
        if vector["message"] == "hapticd.v1.Request":
            body = bytes.fromhex(vector["hex"])
            write(out, f"golden-{vector['name']}", struct.pack(">I", len(body)) + body)


def scenario_texts() -> dict[str, str]:
    texts = {p.stem: p.read_text() for p in sorted((REPO / "bench/scenarios").glob("*.json"))}
    for i, text in enumerate(raw_strings(REPO / "server/sim/test/scenario_parser_test.cc")):
        if text.lstrip().startswith("{"):
            texts[f"scenario_parser_test-{i}"] = text
    return texts


def scenario_seeds(out: Path, texts: dict[str, str]) -> None:
    for name, text in texts.items():
        write(out, name, text.encode())
    # FORMAT.md's example as the parser test holds it, with its `--set` overrides
    base = next(t for n, t in texts.items() if n.startswith("scenario_parser_test"))
    test = (REPO / "server/sim/test/scenario_parser_test.cc").read_text()
    overrides = re.findall(r'"([a-z_]+(?:\.[a-z_0-9]*)+=(?:[^"\\]|\\.)*)"', test)
    for i in range(0, len(overrides), 4):
        lines = "\n".join(codecs.decode(o, "unicode_escape") for o in overrides[i:i + 4])
        write(out, f"overrides-{i // 4:02d}", base.encode() + b"\0" + lines.encode())


def scene_file_seeds(out: Path, texts: dict[str, str]) -> None:
    for name, text in texts.items():
        write(out, name, text.encode())
        try:
            scene = json.loads(text)["scene"]
        except (ValueError, KeyError, TypeError):
            continue
        write(out, f"{name}-scene-only", json.dumps({"scene": scene}).encode())


def mesh_file_seeds(out: Path) -> None:
    write(out, "icosphere.obj", (REPO / "bench/scenarios/meshes/icosphere.obj").read_bytes())
    test = REPO / "server/scene/test/mesh_file_test.cc"
    for i, text in enumerate(raw_strings(test)):
        write(out, f"mesh_file_test-raw-{i}", text.encode())
    for function in ("ParseObj", "ParseStl"):
        for i, text in enumerate(call_literals(test, function)):
            write(out, f"mesh_file_test-{function}-{i}", text.encode("latin-1"))
    vertices, triangles = tetrahedron()
    facets = [[vertices[i] for i in t] for t in triangles]
    ascii_stl = "solid tetra\n"
    for facet in facets:
        ascii_stl += "facet normal 0 0 0\nouter loop\n"
        ascii_stl += "".join(f"vertex {x} {y} {z}\n" for x, y, z in facet)
        ascii_stl += "endloop\nendfacet\n"
    write(out, "tetra-ascii.stl", (ascii_stl + "endsolid tetra\n").encode())
    binary = b"binary tetra".ljust(80, b" ") + struct.pack("<I", len(facets))
    for facet in facets:
        binary += struct.pack("<3f", 0, 0, 0) + b"".join(struct.pack("<3f", *v) for v in facet) + b"\0\0"
    write(out, "tetra-binary.stl", binary)


def tetrahedron() -> tuple[list[tuple[float, float, float]], list[tuple[int, int, int]]]:
    return [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1)], [(0, 2, 1), (0, 1, 3), (0, 3, 2), (1, 2, 3)]


def cube() -> tuple[list[tuple[float, float, float]], list[tuple[int, int, int]]]:
    vertices = [(x, y, z) for z in (0, 1) for y in (0, 1) for x in (0, 1)]
    quads = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]
    return vertices, [t for a, b, c, d in quads for t in ((a, b, c), (a, c, d))]


def icosphere() -> tuple[list[tuple[float, float, float]], list[tuple[int, int, int]]]:
    """One subdivision of an icosahedron, radius 0.5: 42 vertices, 80 triangles."""
    phi = (1 + 5 ** 0.5) / 2
    vertices = [(-1, phi, 0), (1, phi, 0), (-1, -phi, 0), (1, -phi, 0), (0, -1, phi), (0, 1, phi),
                (0, -1, -phi), (0, 1, -phi), (phi, 0, -1), (phi, 0, 1), (-phi, 0, -1), (-phi, 0, 1)]
    faces = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4), (11, 10, 2),
             (10, 7, 6), (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8), (3, 8, 9), (4, 9, 5),
             (2, 4, 11), (6, 2, 10), (8, 6, 7), (9, 8, 1)]
    midpoints: dict[tuple[int, int], int] = {}

    def midpoint(a: int, b: int) -> int:
        key = (min(a, b), max(a, b))
        if key not in midpoints:
            vertices.append(tuple((p + q) / 2 for p, q in zip(vertices[a], vertices[b], strict=True)))
            midpoints[key] = len(vertices) - 1
        return midpoints[key]

    triangles = []
    for a, b, c in faces:
        ab, bc, ca = midpoint(a, b), midpoint(b, c), midpoint(c, a)
        triangles += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
    scaled = [tuple(0.5 * x / math.sqrt(sum(y * y for y in v)) for x in v) for v in vertices]
    return scaled, triangles


class FuzzedData:
    """Builds the bytes FuzzedDataProvider (clang's fuzzer/FuzzedDataProvider.h) decodes
    into given integers: ConsumeIntegralInRange reads from the end of the data, one byte
    per 8 bits of its range, the first byte read the most significant."""

    def __init__(self) -> None:
        self.consumed: list[int] = []

    def integral(self, value: int, low: int, high: int) -> None:
        span, size = high - low, 0
        while size < 8 and (span >> (8 * size)) > 0:
            size += 1
        v = value - low
        self.consumed += [(v >> (8 * (size - 1 - i))) & 0xFF for i in range(size)]

    def data(self) -> bytes:
        return bytes(reversed(self.consumed))


def mesh_validation_input(vertices, triangles, pin: int = 0, embree: bool = False) -> bytes:
    """The fuzz_mesh_validation input for a mesh (its ConsumeMeshObject, in reverse)."""
    data = FuzzedData()
    data.integral(pin, 0, 5)
    data.integral(0 if embree else 1, 0, 3)

    def coordinate(x: float) -> None:
        if float(4 * x).is_integer() and -4 <= 4 * x <= 4:
            data.integral(0, 0, 3)
            data.integral(int(4 * x), -4, 4)
        else:
            data.integral(3, 0, 3)
            data.integral(struct.unpack("<Q", struct.pack("<d", x))[0], 0, 2 ** 64 - 1)

    coordinate(0)
    data.integral(len(vertices), 0, 48)
    for v in vertices:
        for x in v:
            coordinate(x)
    data.integral(len(triangles), 0, 96)
    for t in triangles:
        for i in t:
            data.integral(i, -1, len(vertices))
    return data.data()


def mesh_validation_seeds(out: Path) -> None:
    tv, tt = tetrahedron()
    cv, ct = cube()
    iv, it = icosphere()
    seeds = {
        "tetra-auto": mesh_validation_input(tv, tt),
        "tetra-mesh-embree": mesh_validation_input(tv, tt, pin=5, embree=True),
        "tetra-convex": mesh_validation_input(tv, tt, pin=4),
        "cube-auto": mesh_validation_input(cv, ct),
        "cube-box": mesh_validation_input(cv, ct, pin=2),
        "cube-capsule": mesh_validation_input(cv, ct, pin=3),
        "cube-inside-out": mesh_validation_input(cv, [(a, c, b) for a, b, c in ct], pin=5),
        "icosphere-auto": mesh_validation_input(iv, it),
        "icosphere-sphere": mesh_validation_input(iv, it, pin=1),
        "icosphere-mesh-embree": mesh_validation_input(iv, it, pin=5, embree=True),
        "open-square": mesh_validation_input([(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)], [(0, 1, 2), (0, 2, 3)]),
        "repeated-triangle": mesh_validation_input(tv, [tt[0]] * 32, pin=5),
        "zero-area": mesh_validation_input([(0, 0, 0), (0.5, 0, 0), (1, 0, 0)], [(0, 1, 2)]),
        "nan-vertex": mesh_validation_input(tv[:3] + [(0, math.nan, 1)], tt),
    }
    for name, data in seeds.items():
        write(out, name, data)


def conformance_seeds(out: Path) -> None:
    for path in sorted(CONFORMANCE.glob("*.jsonl")):
        lines = path.read_text().splitlines()
        picked = lines[:LINES_PER_CONFORMANCE_FILE // 2] + lines[-(LINES_PER_CONFORMANCE_FILE // 2):]
        for line in picked:
            case = json.loads(line)
            case.pop("expect", None)
            write(out, case["id"], json.dumps(case).encode())
    for i, text in enumerate(raw_strings(REPO / "server/conformance/test/query_runner_test.cc")):
        if "\n" not in text:
            write(out, f"query_runner_test-{i}", text.encode())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--control-seeds", required=True, help="the make_control_seeds program")
    args = parser.parse_args()
    golden = json.loads((REPO / "proto/golden/vectors.json").read_text())["vectors"]
    texts = scenario_texts()
    datagram_seeds(args.out / "fuzz_datagram", golden)
    control_seeds(args.out / "fuzz_control", golden, args.control_seeds)
    scene_file_seeds(args.out / "fuzz_scene_file", texts)
    scenario_seeds(args.out / "fuzz_scenario", texts)
    mesh_file_seeds(args.out / "fuzz_mesh_file")
    mesh_validation_seeds(args.out / "fuzz_mesh_validation")
    conformance_seeds(args.out / "fuzz_conformance_line")
    counts = ", ".join(f"{folder.name} {len(list(folder.iterdir()))}" for folder in sorted(args.out.iterdir()))
    print(f"seeds: {counts}")


if __name__ == "__main__":
    main()
