"""The command line, `python -m hapticd`:

    scene load FILE      add the objects of a JSON scene file, or one mesh file
    scene show           print the scene as JSON
    scene export FILE    write the scene to a scene file (what scene load and
                         hapticd --scene read back to the same scene)
    scene clear          remove every object
    view                 the scene and the sessions live in the browser (hapticd.view);
                         one JSON line with the page's URL, another when it stops
    demo                 a simulated hand strokes the scene over UDP; one JSON line
    bench latency        round-trip percentiles of a still device; one JSON line
    ur-bridge            a Universal Robots arm as an admittance device; one JSON line
                         at exit (hapticd.ur_bridge; python -m hapticd ur-bridge --help)

Every command takes --server HOST:PORT (default $HAPTICD_SERVER, else 127.0.0.1:7460,
the server's default). Options are spelled out in full; an unknown one is refused.
Exit status: 0 done, 2 bad arguments or input files (the message names the problem),
1 the server refused, failed or could not be reached. What a command prints is strict
JSON: a number JSON cannot hold (an infinite bound, an unbounded representation
error) is printed as the string "inf", "-inf" or "nan".
"""

from __future__ import annotations

import argparse
import json
import os
import pathlib
import signal
import ssl
import sys
from collections.abc import Sequence
from typing import Any

import numpy as np

from hapticd import __version__, ur_bridge
from hapticd._connection import parse_address
from hapticd.client import Client, connect
from hapticd.demo import Trace, plot_trace, run_demo, run_latency_bench
from hapticd.errors import HapticdError, LocalError
from hapticd.objects import (
    DEFAULT_STIFFNESS,
    Box,
    Capsule,
    Convex,
    Material,
    Mesh,
    ObjectSpec,
    Pose,
    Sphere,
)
from hapticd.results import ObjectInfo, SceneInfo
from hapticd.scene_files import MESH_SUFFIXES, read_mesh_file, read_scene_file

DEFAULT_SERVER = "127.0.0.1:7460"


def _positive(text: str) -> float:
    """An argparse type: a finite number > 0."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not (value > 0 and np.isfinite(value)):
        raise argparse.ArgumentTypeError(f"{text!r} must be a finite number > 0")
    return value


def _server_options(parser: argparse.ArgumentParser) -> None:
    """The connection options every command takes."""
    parser.add_argument(
        "--server",
        default=os.environ.get("HAPTICD_SERVER", DEFAULT_SERVER),
        metavar="HOST:PORT",
        help="the server's control channel (default $HAPTICD_SERVER or %(default)s)",
    )
    parser.add_argument(
        "--timeout", type=_positive, default=5.0, metavar="S", help="per-request timeout (s)"
    )
    parser.add_argument("--tls-ca", metavar="FILE", help="use TLS, trusting this CA (PEM)")
    parser.add_argument(
        "--access-token-file", metavar="FILE", help="its first line is the server's token"
    )


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of every command."""
    # no abbreviations: an unknown --flag is refused as unknown, not taken for another
    parser = argparse.ArgumentParser(
        prog="python -m hapticd",
        description="hapticd's command line." + __doc__.split(":", 1)[1],
        formatter_class=argparse.RawDescriptionHelpFormatter,
        allow_abbrev=False,
    )
    parser.add_argument(
        "--version", action="version", version=f"hapticd {__version__} (Python client)"
    )
    commands = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    scene = commands.add_parser("scene", help="load, show or clear the scene", allow_abbrev=False)
    scene_commands = scene.add_subparsers(dest="scene_command", required=True, metavar="ACTION")
    load = scene_commands.add_parser(
        "load", help="add the objects of a scene or mesh file", allow_abbrev=False
    )
    load.add_argument("file", help='JSON scene file ({"scene": {"objects": [...]}}) or OBJ/STL/PLY')
    load.add_argument("--replace", action="store_true", help="clear the scene first")
    load.add_argument("--name", help="a mesh file's object name (default: the file's stem)")
    load.add_argument(
        "--position",
        type=float,
        nargs=3,
        default=(0.0, 0.0, 0.0),
        metavar=("X", "Y", "Z"),
        help="a mesh file's position (m)",
    )
    load.add_argument(
        "--scale", type=_positive, default=1.0, help="a mesh file's scale (0.001: mm)"
    )
    load.add_argument(
        "--stiffness",
        type=_positive,
        default=DEFAULT_STIFFNESS,
        help="a mesh file's N/m (default %(default)s, the server's default)",
    )
    load.add_argument("--representation", default="auto", help="a mesh file's representation")
    _server_options(load)
    show = scene_commands.add_parser("show", help="print the scene as JSON", allow_abbrev=False)
    _server_options(show)
    clear = scene_commands.add_parser("clear", help="remove every object", allow_abbrev=False)
    _server_options(clear)
    export = scene_commands.add_parser(
        "export", help="write the scene to a scene file", allow_abbrev=False
    )
    export.add_argument("file", help="the JSON scene file to write (replaced if it exists)")
    _server_options(export)

    view = commands.add_parser(
        "view", help="show the scene and sessions live in the browser", allow_abbrev=False
    )
    view.add_argument(
        "--port", type=int, default=8080, help="the page's port on 127.0.0.1 (0: any free one)"
    )
    view.add_argument(
        "--rate-hz", type=_positive, default=30.0, help="telemetry rate, in [1, 60] (default 30)"
    )
    view.add_argument(
        "--force-scale",
        type=_positive,
        default=0.01,
        metavar="M_PER_N",
        help="force arrows' length per newton, in (0, 1] m/N (default %(default)s)",
    )
    view.add_argument(
        "--seconds", type=_positive, help="stop after this long (default: until interrupted)"
    )
    _server_options(view)

    demo = commands.add_parser(
        "demo", help="stroke the scene with a simulated device", allow_abbrev=False
    )
    demo.add_argument("--seconds", type=_positive, default=4.0, help="how long (s)")
    demo.add_argument("--rate-hz", type=_positive, default=1000.0, help="the device's rate")
    demo.add_argument("--plot", metavar="FILE.png", help="draw force and position over time")
    demo.add_argument(
        "--remote-mode",
        choices=("direct", "local_model"),
        default="direct",
        help="direct: render each command's force; local_model: render on the device from the "
        "local models the commands carry (default %(default)s)",
    )
    _server_options(demo)

    bench = commands.add_parser("bench", help="measure the realtime channel", allow_abbrev=False)
    bench_commands = bench.add_subparsers(dest="bench_command", required=True, metavar="WHAT")
    latency = bench_commands.add_parser(
        "latency", help="round trips of a still device", allow_abbrev=False
    )
    latency.add_argument("--seconds", type=_positive, default=5.0, help="how long (s)")
    latency.add_argument("--rate-hz", type=_positive, default=1000.0, help="the device's rate")
    _server_options(latency)

    bridge = commands.add_parser(
        "ur-bridge",
        help="drive a Universal Robots arm as an admittance device",
        description=ur_bridge.__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
        allow_abbrev=False,
    )
    ur_bridge.add_arguments(bridge)
    _server_options(bridge)
    return parser


def _connect(args: argparse.Namespace) -> Client:
    """A client for the command's --server and TLS options."""
    parse_address(args.server, "--server")
    tls = None
    if args.tls_ca:
        tls = ssl.create_default_context(cafile=args.tls_ca)
    token = ""
    if args.access_token_file:
        try:
            token = pathlib.Path(args.access_token_file).read_text().splitlines()[0].strip()
        except (OSError, IndexError) as exc:
            raise LocalError(f"--access-token-file {args.access_token_file!r}: {exc}") from exc
    return connect(args.server, timeout_s=args.timeout, tls=tls, access_token=token)


def _read_objects(args: argparse.Namespace) -> list[ObjectSpec]:
    """scene load's objects: a scene file's, or one object of a mesh file."""
    path = pathlib.Path(args.file)
    if path.suffix.lower() in MESH_SUFFIXES:
        vertices, triangles = read_mesh_file(path)
        specs = [
            ObjectSpec(
                name=args.name or path.stem,
                shape=Mesh(vertices * args.scale, triangles, args.representation),
                pose=Pose.of(args.position),
                material=Material(stiffness=args.stiffness),
            )
        ]
    else:
        scene_file = read_scene_file(path)
        specs = scene_file.objects
        if scene_file.tolerance is not None:
            print(
                "hapticd: note: the file's scene.tolerance is not set over the protocol; "
                "the server keeps its own",
                file=sys.stderr,
            )
    return specs


def _load(client: Client, specs: list[ObjectSpec], replace: bool) -> dict[str, Any]:
    """scene load: adds the objects; what was added and the new version."""
    version = client.clear_scene() if replace else 0
    for spec in specs:
        version = client.add_object(spec)
    return {"added": [spec.name for spec in specs], "scene_version": version}


def _finite_or_text(value: float) -> float | str:
    """value for JSON, which has no infinities or NaN: those as "inf", "-inf", "nan"."""
    value = float(value)
    if np.isfinite(value):
        return value
    return "nan" if np.isnan(value) else ("inf" if value > 0 else "-inf")


def _vector(values: np.ndarray[Any, Any]) -> list[float | str]:
    """A vector for JSON (see _finite_or_text)."""
    return [_finite_or_text(v) for v in values]


def _object_json(info: ObjectInfo) -> dict[str, Any]:
    material = info.material
    return {
        "name": info.name,
        "shape": info.shape,
        "representation": info.representation,
        "representation_error": _finite_or_text(info.representation_error),
        "position": _vector(info.pose.position),
        "orientation": _vector(info.pose.orientation),
        "bounds_min": _vector(info.bounds_min),
        "bounds_max": _vector(info.bounds_max),
        "material": {
            "stiffness": _finite_or_text(material.stiffness),
            "damping": _finite_or_text(material.damping),
            "static_friction": _finite_or_text(material.static_friction),
            "dynamic_friction": _finite_or_text(material.dynamic_friction),
            "force_shading": material.force_shading,
        },
        "kinematic": info.kinematic,
        "triangles": info.triangles,
        "closed": info.closed,
        "topology": info.topology,
        "rewound_triangles": info.rewound_triangles,
        "warnings": list(info.warnings),
        "parameters": _shape_json(info),
        "velocity": _vector(info.velocity),
        "angular_velocity": _vector(info.angular_velocity),
        "pinned_representation": info.pinned_representation,
        "mesh_pose": None
        if info.mesh_pose is None
        else {
            "position": _vector(info.mesh_pose.position),
            "orientation": _vector(info.mesh_pose.orientation),
        },
        "shape_digest": f"{info.shape_digest:016x}",
    }


def _shape_json(info: ObjectInfo) -> dict[str, Any]:
    """The represented shape's parameters (a mesh's counts: its data is not read here)."""
    shape = info.represented
    if isinstance(shape, Sphere):
        return {"radius": shape.radius}
    if isinstance(shape, Box):
        return {"half_extents": _vector(shape.half_extents)}
    if isinstance(shape, Capsule):
        return {"radius": shape.radius, "half_length": shape.half_length}
    if isinstance(shape, Convex):
        return {"points": [_vector(point) for point in shape.points]}
    return {}


def scene_json(scene: SceneInfo) -> dict[str, Any]:
    """The scene as a JSON-ready dict."""
    return {
        "version": scene.version,
        "tolerance": _finite_or_text(scene.tolerance),
        "objects": [_object_json(info) for info in scene.objects],
    }


def _strict_json(value: Any) -> Any:
    """value with every float JSON cannot hold as text (see _finite_or_text)."""
    if isinstance(value, float):
        return _finite_or_text(value)
    if isinstance(value, dict):
        return {key: _strict_json(item) for key, item in value.items()}
    if isinstance(value, (list, tuple)):
        return [_strict_json(item) for item in value]
    return value


def _run(args: argparse.Namespace) -> dict[str, Any]:
    """Runs the parsed command; returns the JSON it prints. Input files are read, and a
    plot's directory checked, before connecting."""
    specs = _read_objects(args) if args.command == "scene" and args.scene_command == "load" else []
    bridge = ur_bridge.options_from(args) if args.command == "ur-bridge" else None
    if args.command == "demo" and args.plot and not pathlib.Path(args.plot).parent.is_dir():
        raise LocalError(f"--plot {args.plot!r}: its directory does not exist")
    exporting = args.command == "scene" and args.scene_command == "export"
    if exporting and not pathlib.Path(args.file).resolve().parent.is_dir():
        raise LocalError(f"scene export {args.file!r}: its directory does not exist")
    with _connect(args) as client:
        if args.command == "scene":
            if args.scene_command == "load":
                return _load(client, specs, args.replace)
            if args.scene_command == "clear":
                return {"scene_version": client.clear_scene()}
            if exporting:
                scene = client.export_scene(args.file)
                names = [info.name for info in scene.objects]
                return {"exported": args.file, "objects": names, "scene_version": scene.version}
            return scene_json(client.scene())
        if args.command == "view":
            return _view(client, args)
        if args.command == "demo":
            trace = Trace() if args.plot else None
            summary = run_demo(
                client,
                args.seconds,
                rate_hz=args.rate_hz,
                trace=trace,
                remote_mode=args.remote_mode,
            )
            if trace is not None:
                plot_trace(trace, args.plot)
                summary["plot"] = args.plot
            return summary
        if bridge is not None:
            return ur_bridge.run_bridge(bridge, client)
        return run_latency_bench(client, args.seconds, rate_hz=args.rate_hz)


def _view(client: Client, args: argparse.Namespace) -> dict[str, Any]:
    """view: serves the page, prints its URL, and follows the server until interrupted,
    --seconds pass, or the server fails; what the view did."""
    try:
        from hapticd import view  # viser and scipy, only for this command
    except ImportError as exc:
        raise LocalError(
            f"the view needs viser and scipy ({exc}): pip install 'hapticd[view]'"
        ) from exc

    handle = view.serve(
        client, port=args.port, rate_hz=args.rate_hz, force_scale_m_per_n=args.force_scale
    )
    print(json.dumps({"url": handle.url}), flush=True)
    reason = "seconds"
    # SIGTERM (a service manager's stop) ends the view as Ctrl-C does
    signal.signal(signal.SIGTERM, signal.default_int_handler)
    try:
        handle.wait(args.seconds)
        handle.stop()
        if handle.error is not None:
            raise handle.error
    except KeyboardInterrupt:
        handle.stop()
        reason = "interrupted"
    counters = handle.counters
    return {
        "stopped": reason,
        "samples": counters.samples,
        "scene_reads": counters.scene_reads,
        "mesh_reads": counters.mesh_reads,
    }


def main(argv: Sequence[str] | None = None) -> int:
    """Runs the command line; returns the exit status."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        result = _run(args)
    except LocalError as exc:
        parser.exit(2, f"hapticd: error: {exc}\n")
    except HapticdError as exc:
        parser.exit(1, f"hapticd: {type(exc).__name__}: {exc}\n")
    except KeyboardInterrupt:
        return 130
    print(json.dumps(_strict_json(result), allow_nan=False))
    ur_bridge.exit_if_robot_link_abandoned(0)
    return 0


if __name__ == "__main__":
    sys.exit(main())
