"""The whole scene read back, mesh data included, however large: one GetScene with every
mesh's vertices and triangles when they fit in a reply (the server's bound: 48 MiB of
mesh data, and its frame limit), else the scene without them and then each mesh's in a
request of its own. A moving scene changes version every millisecond, so the meshes
read later are matched to the first reading by name and shape digest (which moving
does not change); a mesh whose shape changed in between (an update) makes the whole
read start again, at most READ_ATTEMPTS times.

Written sans I/O, as the clients' calls are (_calls.py): read(**mesh_data) is the call
that reads the scene once, and read_whole_scene is a call made of such calls, which
Client and AsyncClient drive alike.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Generator, Sequence
from typing import Any

from hapticd.errors import HapticdError, RemoteError
from hapticd.results import ObjectInfo, SceneInfo

# How many times a read is started again when a mesh changed while it was being read.
READ_ATTEMPTS = 3
# The server's refusals of a reply that is too large.
TOO_LARGE = ("RESOURCE_EXHAUSTED", "FRAME_TOO_LARGE")

# A call (_calls.Call): yields requests, is sent their replies, returns its result.
ReadCall = Generator[Any, Any, SceneInfo]
SceneReader = Callable[..., ReadCall]


def read_whole_scene(read: SceneReader) -> Generator[Any, Any, SceneInfo]:
    """The scene with every mesh's data; read(include_mesh_data=..., mesh_data_for=...)
    is the call reading the scene once (_calls.scene with its timeout bound).
    HapticdError when a mesh keeps changing while it is read."""
    try:
        return (yield from read(include_mesh_data=True))
    except RemoteError as exc:
        if exc.code not in TOO_LARGE:
            raise
    for _ in range(READ_ATTEMPTS):
        scene = yield from read()
        objects = yield from _with_meshes(read, scene.objects)
        if objects is not None:
            return dataclasses.replace(scene, objects=objects)
    raise HapticdError(
        f"the scene's meshes changed each of the {READ_ATTEMPTS} times it was read; "
        "export it while no client updates them"
    )


def _with_meshes(
    read: SceneReader, objects: Sequence[ObjectInfo]
) -> Generator[Any, Any, list[ObjectInfo] | None]:
    """objects with each mesh's data read on its own, or None when a mesh's shape
    changed (or it went) since objects were read."""
    result: list[ObjectInfo] = []
    for info in objects:
        if not info.pinned_representation or info.mesh is not None:
            result.append(info)
            continue
        try:
            alone = (yield from read(mesh_data_for=[info.name])).object(info.name)
        except (KeyError, RemoteError) as exc:
            if isinstance(exc, RemoteError) and exc.code != "NOT_FOUND":
                raise
            return None
        if alone.shape_digest != info.shape_digest or alone.mesh is None:
            return None
        represented = alone.mesh if info.representation == "mesh" else info.represented
        result.append(dataclasses.replace(info, mesh=alone.mesh, represented=represented))
    return result
