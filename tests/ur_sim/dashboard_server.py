"""The dashboard server (TCP 29999): a greeting line, then one command a line, one answer
a line, worded like PolyScope 5's dashboard server. answer() is the protocol; handle() is
the socket loop around it."""

from __future__ import annotations

import socket

from .controller import (
    PLAYING,
    ROBOT_MODES,
    RUNTIME_STATES,
    SAFETY_MODES,
    Controller,
)

GREETING = "Connected: Universal Robots Dashboard Server"
MAX_LINE_BYTES = 4096


def answer(controller: Controller, line: str) -> tuple[str, bool]:
    """The reply to one command line (without its newline), and whether to close the
    connection after it. Takes the controller's lock."""
    command = line.strip()
    lowered = command.lower()
    with controller.lock:
        c = controller
        if lowered == "quit":
            return "Disconnected", True
        if lowered == "robotmode":
            return f"Robotmode: {ROBOT_MODES.get(c.robot_mode, 'UNKNOWN')}", False
        if lowered == "safetymode":
            return f"Safetymode: {SAFETY_MODES.get(c.safety_mode, 'UNKNOWN')}", False
        if lowered == "safetystatus":
            return f"Safetystatus: {SAFETY_MODES.get(c.safety_mode, 'UNKNOWN')}", False
        if lowered == "programstate":
            return f"{RUNTIME_STATES.get(c.runtime_state, 'STOPPED')} {c.program_name}", False
        if lowered == "running":
            return f"Program running: {'true' if c.runtime_state == PLAYING else 'false'}", False
        if lowered == "is in remote control":
            return ("true" if c.remote_control else "false"), False
        if lowered == "polyscopeversion":
            return f"URSoftware {c.config.polyscope_version} (Oct 05 2023)", False
        if lowered == "version":
            return c.config.polyscope_version, False
        if lowered == "get serial number":
            return c.config.serial_number, False
        if lowered == "get robot model":
            return c.config.robot_model, False
        if lowered == "get loaded program":
            return (
                "No program loaded"
                if c.last_script is None
                else f"Loaded program: {c.program_name}"
            ), False
        if lowered == "isprogramsaved":
            return f"true {c.program_name}", False
        if lowered == "power on":
            c.power_on()
            return "Powering on", False
        if lowered == "power off":
            c.power_off()
            return "Powering off", False
        if lowered == "brake release":
            c.brake_release()
            return "Brake releasing", False
        if lowered == "unlock protective stop":
            return c.unlock_protective_stop(), False
        if lowered == "close safety popup":
            return "closing safety popup", False
        if lowered == "close popup":
            return "closing popup", False
        if lowered.startswith("popup "):
            return "showing popup", False
        if lowered == "restart safety":
            c.release_emergency_stop()
            return "Restarting safety", False
        if lowered == "stop":
            # answered "Stopped" also when nothing runs: ur_rtde's constructor calls stop
            # right after its own stop-script command and throws on any other answer
            c.program_ended("dashboard stop")
            return "Stopped", False
        if lowered == "play":
            return ("Starting program" if c.replay() else "Failed to execute: play"), False
        if lowered == "pause":
            return ("Pausing program" if c.pause() else "Failed to execute: pause"), False
        if lowered.startswith("addtolog "):
            c.event("dashboard_log", message=command[9:])
            return "Added log message", False
        if lowered.startswith("setuserrole "):
            return f"Setting user role: {command[12:]}", False
        if lowered == "shutdown":
            return "Shutting down", False
    return f"could not understand: '{command}'", False


def make_handler(controller: Controller):
    """A Listener handler serving one dashboard client."""

    def handle(sock: socket.socket, _address: tuple) -> None:
        with sock:
            sock.sendall((GREETING + "\n").encode())
            buffer = b""
            while True:
                data = sock.recv(4096)
                if not data:
                    return
                buffer += data
                if len(buffer) > MAX_LINE_BYTES and b"\n" not in buffer:
                    sock.sendall(b"could not understand: line too long\n")
                    buffer = b""
                while b"\n" in buffer:
                    raw, buffer = buffer.split(b"\n", 1)
                    reply, close = answer(controller, raw.decode("utf-8", errors="replace"))
                    sock.sendall((reply + "\n").encode())
                    if close:
                        return

    return handle
