"""The test control channel: JSON lines over TCP, one request object a line, one answer
object a line ({"ok": true, ...} or {"ok": false, "error": "..."}). handle_request() is
the protocol; make_handler() the socket loop. Requests are listed in README.md."""

from __future__ import annotations

import json
import math
import random
import socket
from collections.abc import Callable

from .arm import Person
from .controller import Controller

MAX_LINE_BYTES = 1 << 16


class RequestError(Exception):
    """A request that names a bad value; its text goes back as the error."""


def _vector(value, length: int, name: str) -> list[float]:
    """A list of `length` finite numbers, padded with zeros from 3 to 6 entries."""
    if (
        not isinstance(value, list)
        or len(value) not in {length, 3}
        or not all(isinstance(x, (int, float)) and math.isfinite(x) for x in value)
    ):
        raise RequestError(f"{name} must be a list of {length} finite numbers, got {value!r}")
    return [float(x) for x in value] + [0.0] * (length - len(value))


def _vec3(value, name: str) -> tuple[float, float, float]:
    x, y, z = _vector(value, 3, name)
    return (x, y, z)


def _number(request: dict, key: str, default: float | None = None) -> float:
    value = request.get(key, default)
    if not isinstance(value, (int, float)) or not math.isfinite(value):
        raise RequestError(f"{key} must be a finite number, got {value!r}")
    return float(value)


def _person(c: Controller, request: dict) -> Person:
    """A new Person from a "person" request; times are relative to now."""
    noise = request.get("noise") or {}
    person = Person(
        noise_sigma=_number(noise, "sigma", 0.0),
        rng=random.Random(int(noise.get("seed", c.config.seed))),
    )
    if "force" in request:
        person.kind, person.force = "constant", _vec3(request["force"], "force")
    elif "ramp" in request:
        ramp = request["ramp"]
        person.kind = "ramp"
        person.force = _vec3(ramp.get("from", [0, 0, 0]), "ramp.from")
        person.force_to = _vec3(ramp.get("to"), "ramp.to")
        person.duration_s = _number(ramp, "duration_s")
        person.t0 = c.t + _number(ramp, "delay_s", 0.0)
    elif "step" in request:
        step = request["step"]
        person.kind = "step"
        person.force = _vec3(step.get("before", [0, 0, 0]), "step.before")
        person.force_to = _vec3(step.get("after"), "step.after")
        person.t0 = c.t + _number(step, "at_s")
    elif "spring" in request:
        spring = request["spring"]
        person.kind = "spring"
        person.anchor = _vec3(spring.get("anchor"), "spring.anchor")
        person.k = _number(spring, "k")
        person.damping = _number(spring, "damping", 0.0)
        person.max_force = _number(spring, "max_force") if "max_force" in spring else math.inf
    elif request.get("none"):
        person.kind = "none"
    else:
        raise RequestError("person needs one of force, ramp, step, spring or none")
    return person


def _sensors(c: Controller, request: dict) -> list:
    which = request.get("sensor", "internal")
    sensors = {
        "internal": [c.tcp_sensor],
        "external": [c.external_sensor],
        "both": [c.tcp_sensor, c.external_sensor],
    }
    if which not in sensors:
        raise RequestError(f"sensor must be internal, external or both, got {which!r}")
    return sensors[which]


def handle_request(c: Controller, request: dict, drop_connections: Callable[[], int]) -> dict:
    """The answer to one request (takes the controller's lock)."""
    cmd = request.get("cmd")
    if cmd == "drop_connections" or (cmd == "fault" and request.get("kind") == "drop_connections"):
        with c.lock:
            c.event("drop_connections")
        return {"ok": True, "dropped": drop_connections()}
    with c.lock:
        if cmd == "ping":
            return {"ok": True, "t": c.t, "host_time": c.host_time}
        if cmd == "state":
            return {"ok": True, **c.state()}
        if cmd == "trace":
            since = request.get("since_host_time")
            last = request.get("last")
            return {"ok": True, **c.trace.snapshot(since, last)}
        if cmd == "person":
            c.person = _person(c, request)
            c.event("person", kind=c.person.kind)
            # t: the controller time the profile counts from (its delay_s and at_s too)
            return {"ok": True, "kind": c.person.kind, "t": c.t}
        if cmd == "enable":
            return _set_input(c, c.config.enable_input_bit, request.get("on"))
        if cmd == "digital_input":
            bit = request.get("bit")
            if not isinstance(bit, int) or not 0 <= bit < 16:
                raise RequestError(f"bit must be an integer in [0, 15], got {bit!r}")
            return _set_input(c, bit, request.get("on"))
        if cmd == "remote_control":
            c.remote_control = bool(request.get("on"))
            return {"ok": True, "remote_control": c.remote_control}
        if cmd == "fault":
            return _fault(c, request)
    raise RequestError(f"unknown cmd {cmd!r}")


def _set_input(c: Controller, bit: int, on) -> dict:
    if not isinstance(on, bool):
        raise RequestError(f"on must be true or false, got {on!r}")
    c.digital_inputs = (c.digital_inputs | (1 << bit)) if on else (c.digital_inputs & ~(1 << bit))
    c.event("digital_input", bit=bit, on=on)
    return {"ok": True, "digital_inputs": c.digital_inputs}


def _fault(c: Controller, request: dict) -> dict:
    kind = request.get("kind")
    if kind == "protective_stop":
        c.raise_protective_stop("control channel")
    elif kind == "emergency_stop":
        c.emergency_stop()
    elif kind == "release_emergency_stop":
        c.release_emergency_stop()
    elif kind == "drift":
        rate = _vector(request.get("rate"), 6, "rate")
        for sensor in _sensors(c, request):
            sensor.start_drift(rate, c.t)
    elif kind == "jump":
        bias = _vector(request.get("bias"), 6, "bias")
        for sensor in _sensors(c, request):
            sensor.jump(bias)
    elif kind == "clear_sensor":
        for sensor in _sensors(c, request):
            sensor.clear_faults(c.t)
    elif kind == "modbus_silence":
        # a Modbus server that stops answering (a cable pulled), or answers again
        device, on = request.get("device"), request.get("on")
        if device not in ("ft", "ur"):
            raise RequestError(f"device must be 'ft' or 'ur', got {device!r}")
        if not isinstance(on, bool):
            raise RequestError(f"on must be true or false, got {on!r}")
        c.silent_modbus = (c.silent_modbus | {device}) if on else (c.silent_modbus - {device})
    else:
        raise RequestError(f"unknown fault kind {kind!r}")
    c.event("fault", kind=kind)
    # t: the controller time the fault took effect (a drift counts from it)
    return {"ok": True, "kind": kind, "t": c.t}


def make_handler(controller: Controller, drop_connections: Callable[[], int]):
    """A Listener handler serving one control-channel client."""

    def handle(sock: socket.socket, _address: tuple) -> None:
        with sock, sock.makefile("rb") as reader:
            while True:
                line = reader.readline(MAX_LINE_BYTES + 1)
                if not line:
                    return
                try:
                    if len(line) > MAX_LINE_BYTES:
                        raise RequestError(f"request longer than {MAX_LINE_BYTES} bytes")
                    request = json.loads(line)
                    if not isinstance(request, dict):
                        raise RequestError("a request must be a JSON object")
                    reply = handle_request(controller, request, drop_connections)
                except (RequestError, ValueError, TypeError, AttributeError) as exc:
                    reply = {"ok": False, "error": str(exc)}
                sock.sendall((json.dumps(reply) + "\n").encode())
                if len(line) > MAX_LINE_BYTES:
                    return

    return handle
