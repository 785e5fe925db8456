"""The device side of a local-model session (remote_mode="local_model"): the server
sends the device models of the scene near it, in fragments carried by its commands, and
the device renders its force itself, at its own rate, from the newest one.

The rendering is the server's own C++ (server/remote/local_model.h, the same library
hapticd-proxy and the simulator's device use), loaded with ctypes from
libhapticd_local_model.so (clients/cpp/c_api/local_model_c_api.h): $HAPTICD_LOCAL_MODEL_LIB
when set, else the build/lib/ of the checkout this package runs from (deploy/build.sh
builds it). The fragments are put together here.
"""

from __future__ import annotations

import ctypes
import os
import pathlib
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from hapticd import _validate as check
from hapticd._validate import FloatArray
from hapticd.errors import LocalError, ProtocolError
from hapticd.v1 import hapticd_pb2 as pb

LIBRARY_NAME = "libhapticd_local_model.so"
# The wire's bounds (server/net/datagram_codec.h): fragments of 1024 bytes, at most 96.
CHUNK_BYTES = 1024
MAX_FRAGMENTS = 96
_ERROR_BYTES = 512

_Vec3 = ctypes.c_double * 3


def _library_path() -> pathlib.Path:
    """Where the library is: $HAPTICD_LOCAL_MODEL_LIB, else the checkout's build/lib."""
    named = os.environ.get("HAPTICD_LOCAL_MODEL_LIB")
    if named:
        return pathlib.Path(named)
    for parent in pathlib.Path(__file__).resolve().parents:
        candidate = parent / "build" / "lib" / LIBRARY_NAME
        if candidate.is_file():
            return candidate
    raise LocalError(
        f"{LIBRARY_NAME} was not found under the build/lib of any directory above "
        f"{pathlib.Path(__file__).parent} and HAPTICD_LOCAL_MODEL_LIB is not set; build it with "
        "deploy/build.sh or point HAPTICD_LOCAL_MODEL_LIB at it"
    )


_library: ctypes.CDLL | None = None


def _load() -> ctypes.CDLL:
    global _library
    if _library is not None:
        return _library
    path = _library_path()
    try:
        library = ctypes.CDLL(str(path))
    except OSError as exc:
        raise LocalError(f"cannot load {path}: {exc}") from exc
    p, u8, size, double = ctypes.c_void_p, ctypes.c_char_p, ctypes.c_size_t, ctypes.c_double
    library.hapticd_local_renderer_new.restype = p
    library.hapticd_local_renderer_new.argtypes = [u8, size, ctypes.c_char_p, size]
    library.hapticd_local_renderer_free.restype = None
    library.hapticd_local_renderer_free.argtypes = [p]
    library.hapticd_local_renderer_accept.restype = ctypes.c_int
    library.hapticd_local_renderer_accept.argtypes = [p, u8, size, double, ctypes.c_char_p, size]
    library.hapticd_local_renderer_tick.restype = None
    library.hapticd_local_renderer_tick.argtypes = [
        p, _Vec3, _Vec3, _Vec3, double, _Vec3, _Vec3, ctypes.POINTER(ctypes.c_int), _Vec3
    ]
    library.hapticd_local_renderer_version.restype = ctypes.c_uint64
    library.hapticd_local_renderer_version.argtypes = [p]
    library.hapticd_local_renderer_covers.restype = ctypes.c_int
    library.hapticd_local_renderer_covers.argtypes = [p, _Vec3]
    library.hapticd_device_channel_new.restype = p
    library.hapticd_device_channel_new.argtypes = [u8, size, double, ctypes.c_char_p, size]
    library.hapticd_device_channel_free.restype = None
    library.hapticd_device_channel_free.argtypes = [p]
    library.hapticd_device_channel_sample.restype = ctypes.c_int
    library.hapticd_device_channel_sample.argtypes = [
        p, double, _Vec3, _Vec3, _Vec3, ctypes.c_double * 2
    ]
    library.hapticd_device_channel_surface_velocity.restype = None
    library.hapticd_device_channel_surface_velocity.argtypes = [p, _Vec3]
    library.hapticd_device_channel_limit.restype = ctypes.c_int
    library.hapticd_device_channel_limit.argtypes = [p, double, _Vec3, double, _Vec3]
    _library = library
    return library


@dataclass(frozen=True, eq=False)
class LocalForce:
    """One tick of the device's own rendering: the force to render (N), the avatar (its
    proxy, m), whether it touches the scene, and the touched surface's own velocity at
    the avatar (m/s; zero when not touching or the surface is still)."""

    force: FloatArray
    avatar: FloatArray
    contact: bool
    surface_velocity: FloatArray


class ModelAssembler:
    """Puts a model's fragments together. A newer version's fragment drops what an older
    one had gathered; older versions, and fragments whose fields break the wire's bounds
    or disagree with their version's, are ignored (counted in rejected)."""

    def __init__(self) -> None:
        self.version = 0
        self.rejected = 0
        self._count = 0
        self._parts: dict[int, bytes] = {}
        self._done = 0  # the newest version completed

    def offer(self, fragment: pb.ModelFragment) -> bytes | None:
        """Takes a fragment; the model's whole encoding when it completed one."""
        count, index, data = fragment.count, fragment.index, fragment.data
        if not (1 <= count <= MAX_FRAGMENTS and index < count and len(data) <= CHUNK_BYTES):
            self.rejected += 1
            return None
        if fragment.version <= self._done or fragment.version < self.version:
            return None
        if fragment.version > self.version:
            self.version, self._count, self._parts = fragment.version, count, {}
        last = index == count - 1
        if count != self._count or (len(data) != CHUNK_BYTES and not last) or not data:
            self.rejected += 1
            return None
        self._parts[index] = data
        if len(self._parts) < self._count:
            return None
        self._done = self.version
        encoded = b"".join(self._parts[i] for i in range(self._count))
        self._parts = {}
        return encoded


class LocalRenderer:
    """The server's renderer for one session, on the device's side: built from the
    session's own OpenSession request (SessionInfo.open_request), so it renders with the
    same avatar, method and limits the server would. close() frees it (or leave its with
    block)."""

    def __init__(self, open_request: bytes) -> None:
        self._library = _load()
        error = ctypes.create_string_buffer(_ERROR_BYTES)
        handle = self._library.hapticd_local_renderer_new(
            open_request, len(open_request), error, _ERROR_BYTES
        )
        if not handle:
            raise LocalError(f"the local renderer refused the session: {error.value.decode()}")
        self._handle: int | None = handle
        self.assembler = ModelAssembler()
        self.models_taken = 0
        self.models_rejected = 0
        self.avatar = np.zeros(3)

    def __enter__(self) -> LocalRenderer:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()

    def close(self) -> None:
        """Frees the renderer. Idempotent."""
        if self._handle is not None:
            self._library.hapticd_local_renderer_free(self._handle)
            self._handle = None

    def _live(self) -> int:
        if self._handle is None:
            raise LocalError("the local renderer is closed")
        return self._handle

    @property
    def model_version(self) -> int:
        """The model rendered from (0: none yet)."""
        return int(self._library.hapticd_local_renderer_version(self._live()))

    def accept(self, encoded: bytes, now_s: float) -> bool:
        """Renders from the model in encoded (a LocalModel's bytes) from the next tick,
        its kinematic objects moved on to now_s (the session's clock). False when it is
        not newer than the one held; ProtocolError naming the bad field when it does not
        decode (the model held stays)."""
        error = ctypes.create_string_buffer(_ERROR_BYTES)
        taken = self._library.hapticd_local_renderer_accept(
            self._live(), encoded, len(encoded), check.number(now_s, "now_s"), error, _ERROR_BYTES
        )
        if taken < 0:
            self.models_rejected += 1
            raise ProtocolError(f"the server's local model does not decode: {error.value.decode()}")
        self.models_taken += taken
        return bool(taken == 1)

    def offer(self, fragment: pb.ModelFragment, now_s: float) -> bool:
        """Takes a fragment; True when it completed a model that was taken."""
        encoded = self.assembler.offer(fragment)
        return encoded is not None and self.accept(encoded, now_s)

    def tick(
        self, position: ArrayLike, velocity: ArrayLike, held_force: ArrayLike, dt: float
    ) -> LocalForce:
        """One tick of dt s (> 0): the handle at position (m) moving at velocity (m/s),
        after held_force (N) was rendered since the previous tick."""
        p = _Vec3(*check.vector3(position, "position"))
        v = _Vec3(*check.vector3(velocity, "velocity"))
        f = _Vec3(*check.vector3(held_force, "held_force"))
        step = check.positive(dt, "dt")
        force, avatar, contact, surface = _Vec3(), _Vec3(), ctypes.c_int(0), _Vec3()
        self._library.hapticd_local_renderer_tick(
            self._live(), p, v, f, step, force, avatar, ctypes.byref(contact), surface
        )
        self.avatar = np.array(avatar[:], dtype=np.float64)
        rendered = np.array(force[:], dtype=np.float64)
        moving = np.array(surface[:], dtype=np.float64)
        return LocalForce(rendered, self.avatar.copy(), bool(contact.value), moving)

    def covers(self, position: ArrayLike) -> bool:
        """Whether the avatar at position lies within the model's ball."""
        p = _Vec3(*check.vector3(position, "position"))
        return bool(self._library.hapticd_local_renderer_covers(self._live(), p))


class DeviceChannel:
    """The device's end of a session's channel (clients/cpp/c_api/channel_c_api.h, the
    C++ that hapticd-proxy runs): two-port passivity's port (its damper acts when the
    session asked for tdpa, else it only observes) and the deadband of its states, both
    read from the session's own OpenSession request. mass: the handle's, kg (> 0).
    close() frees it."""

    SEND, KEEPALIVE, HOLD = 1, 2, 0

    def __init__(self, open_request: bytes, mass: float) -> None:
        self._library = _load()
        error = ctypes.create_string_buffer(_ERROR_BYTES)
        handle = self._library.hapticd_device_channel_new(
            open_request, len(open_request), check.number(mass, "mass"), error, _ERROR_BYTES
        )
        if not handle:
            raise LocalError(
                f"the device's channel end refused the session: {error.value.decode()}"
            )
        self._handle: int | None = handle
        self.energy_in = 0.0
        self.energy_out = 0.0

    def close(self) -> None:
        """Frees it. Idempotent."""
        if self._handle is not None:
            self._library.hapticd_device_channel_free(self._handle)
            self._handle = None

    def _live(self) -> int:
        if self._handle is None:
            raise LocalError("the device's channel end is closed")
        return self._handle

    def sample(
        self, t: float, position: ArrayLike, velocity: ArrayLike, held_force: ArrayLike
    ) -> int:
        """A sample at the start of a tick at t s (non-decreasing): observes the work
        held_force (N) did over the handle's move to position (m); what becomes of its
        state: SEND, KEEPALIVE or HOLD (the deadband holds it back)."""
        p = _Vec3(*check.vector3(position, "position"))
        v = _Vec3(*check.vector3(velocity, "velocity"))
        f = _Vec3(*check.vector3(held_force, "held_force"))
        energy = (ctypes.c_double * 2)()
        verdict = self._library.hapticd_device_channel_sample(
            self._live(), check.number(t, "t"), p, v, f, energy
        )
        self.energy_in, self.energy_out = float(energy[0]), float(energy[1])
        return int(verdict)

    def surface_velocity(self, velocity: ArrayLike) -> None:
        """A local-model session's, each tick after rendering: the velocity (m/s) of the
        surface the force pushes from (LocalForce.surface_velocity), which the port, a
        one-port on the local rendering, observes and predicts relative to."""
        v = _Vec3(*check.vector3(velocity, "velocity"))
        self._library.hapticd_device_channel_surface_velocity(self._live(), v)

    def limit(self, server_energy_in: float, force: ArrayLike, dt: float) -> FloatArray:
        """The force (N) to hold over the coming dt s: force saturated at the session's
        max_force, and under tdpa no more than server_energy_in (J) allows (a local-model
        session's: no more than the hand put into its local rendering)."""
        f = _Vec3(*check.vector3(force, "force"))
        out = _Vec3()
        self._library.hapticd_device_channel_limit(
            self._live(), float(server_energy_in), f, check.positive(dt, "dt"), out
        )
        return np.array(out[:], dtype=np.float64)
