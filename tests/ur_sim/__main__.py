"""Command line: start a simulated UR controller and serve until SIGTERM or SIGINT.

    PYTHONPATH=tests python -m ur_sim --host 127.0.0.2 --control-port 0

When every port listens it prints one JSON line on stdout with its endpoints, e.g.
{"host": "127.0.0.2", "rtde": 30004, "dashboard": 29999, "script": 30003, ...}.
"""

from __future__ import annotations

import argparse
import gc
import json
import logging
import signal
import sys
import threading

from . import clock
from .arm import ArmLimits
from .control_channel import make_handler as control_handler
from .controller import (
    IDLE,
    POWER_OFF,
    RUNNING,
    SAFETY_NORMAL,
    SAFETY_PROTECTIVE_STOP,
    SAFETY_ROBOT_EMERGENCY_STOP,
    Controller,
    ControllerConfig,
)
from .dashboard_server import make_handler as dashboard_handler
from .modbus_servers import ModbusServers
from .rtde_server import RtdeServer
from .script_server import make_handler as script_handler
from .tcp import Listener

log = logging.getLogger("ur_sim")

# --robot-mode: (robot mode, safety mode) at start
START_MODES = {
    "running": (RUNNING, SAFETY_NORMAL),
    "idle": (IDLE, SAFETY_NORMAL),
    "power_off": (POWER_OFF, SAFETY_NORMAL),
    "protective_stop": (RUNNING, SAFETY_PROTECTIVE_STOP),
    "emergency_stop": (POWER_OFF, SAFETY_ROBOT_EMERGENCY_STOP),
}
E_SERIES_VERSION = (5, 15, 0, 112233)
CB3_VERSION = (3, 15, 7, 106331)


def _floats(count: int):
    def parse(text: str) -> tuple[float, ...]:
        try:
            values = tuple(float(x) for x in text.split(","))
        except ValueError as exc:
            raise argparse.ArgumentTypeError(
                f"expected {count} comma-separated numbers, got {text!r}"
            ) from exc
        if len(values) != count:
            raise argparse.ArgumentTypeError(
                f"expected {count} comma-separated numbers, got {text!r}"
            )
        return values

    return parse


def _version(text: str) -> tuple[int, int, int, int]:
    parts = text.split(".")
    if len(parts) != 4 or not all(p.isdigit() for p in parts):
        raise argparse.ArgumentTypeError(f"expected major.minor.bugfix.build, got {text!r}")
    return tuple(int(p) for p in parts)  # type: ignore[return-value]


def _positive(text: str) -> float:
    value = float(text)
    if not value > 0.0:
        raise argparse.ArgumentTypeError(f"must be positive, got {text!r}")
    return value


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    p = argparse.ArgumentParser(
        prog="ur_sim", description="A protocol-level simulator of a Universal Robots controller."
    )
    p.add_argument("--host", default="127.0.0.1", help="bind address (default 127.0.0.1)")
    p.add_argument(
        "--rate-hz",
        type=int,
        choices=(500, 125),
        default=500,
        help="controller rate: 500 (e-Series, reports 5.15) or 125 (CB3, reports 3.15)",
    )
    p.add_argument(
        "--controller-version",
        type=_version,
        help="override the reported version, e.g. 5.11.1.108318",
    )
    p.add_argument("--rtde-port", type=int, default=30004)
    p.add_argument("--dashboard-port", type=int, default=29999)
    p.add_argument("--script-port", type=int, default=30003)
    p.add_argument("--secondary-port", type=int, default=30002)
    p.add_argument(
        "--ur-modbus-port",
        type=int,
        default=0,
        help="the controller's Modbus server (502 on a robot; 0 = any free port)",
    )
    p.add_argument(
        "--ft-modbus-port",
        type=int,
        default=0,
        help="the external force-torque sensor (0 = any free port)",
    )
    p.add_argument(
        "--control-port",
        type=int,
        default=0,
        help="JSON-lines test control channel (0 = any free port)",
    )
    p.add_argument(
        "--start-pose",
        type=_floats(6),
        default=(0.4, -0.1, 0.3, 0.0, 3.1416, 0.0),
        metavar="X,Y,Z,RX,RY,RZ",
        help="TCP pose at start, base frame, m and rad",
    )
    p.add_argument(
        "--max-tcp-speed", type=_positive, default=1.0, help="Cartesian speed limit, m/s"
    )
    p.add_argument(
        "--max-tcp-accel", type=_positive, default=20.0, help="Cartesian acceleration limit, m/s^2"
    )
    p.add_argument(
        "--response-time-s",
        type=_positive,
        help="servo time constant; default: servoL's lookahead_time",
    )
    p.add_argument(
        "--safety-stop-decel",
        type=_positive,
        default=20.0,
        help="deceleration of protective, emergency and program stops, m/s^2",
    )
    p.add_argument(
        "--protective-stop-unlock-delay-s",
        type=float,
        default=5.0,
        help="how long after a protective stop the dashboard refuses to unlock it",
    )
    p.add_argument(
        "--enable-input-bit",
        type=int,
        default=0,
        choices=range(16),
        metavar="0..15",
        help="the digital input the control channel's enable command drives",
    )
    p.add_argument("--seed", type=int, default=0, help="seed of the person's force noise")
    p.add_argument("--trace-file", help="write the trace as JSON lines here at exit")
    p.add_argument("--trace-seconds", type=_positive, default=60.0, help="how much trace to keep")
    control = p.add_mutually_exclusive_group()
    control.add_argument(
        "--remote-control", dest="remote_control", action="store_true", default=True
    )
    control.add_argument("--local-control", dest="remote_control", action="store_false")
    p.add_argument(
        "--robot-mode", choices=sorted(START_MODES), default="running", help="state at start"
    )
    p.add_argument("--log-level", default="warning", choices=("debug", "info", "warning", "error"))
    return p.parse_args(argv)


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    logging.basicConfig(
        level=args.log_level.upper(), stream=sys.stderr, format="ur_sim %(levelname)s %(message)s"
    )
    version = args.controller_version or (E_SERIES_VERSION if args.rate_hz == 500 else CB3_VERSION)
    config = ControllerConfig(
        rate_hz=args.rate_hz,
        version=version,
        start_pose=args.start_pose,
        limits=ArmLimits(
            max_speed=args.max_tcp_speed,
            max_accel=args.max_tcp_accel,
            response_time_s=args.response_time_s,
            safety_stop_decel=args.safety_stop_decel,
        ),
        unlock_delay_s=args.protective_stop_unlock_delay_s,
        seed=args.seed,
        trace_seconds=args.trace_seconds,
        enable_input_bit=args.enable_input_bit,
    )
    robot_mode, safety_mode = START_MODES[args.robot_mode]
    controller = Controller(config, robot_mode, safety_mode, args.remote_control)

    stop = threading.Event()
    signal.signal(signal.SIGTERM, lambda *_: stop.set())
    signal.signal(signal.SIGINT, lambda *_: stop.set())

    rtde = RtdeServer(controller)
    controller.publish = rtde.publish
    listeners = [
        Listener("rtde", args.host, args.rtde_port, rtde.handle),
        Listener("dashboard", args.host, args.dashboard_port, dashboard_handler(controller)),
        Listener("script", args.host, args.script_port, script_handler(controller)),
        Listener("secondary", args.host, args.secondary_port, script_handler(controller)),
        Listener(
            "control", args.host, args.control_port, control_handler(controller, rtde.drop_all)
        ),
    ]
    modbus = ModbusServers(controller, args.host, args.ur_modbus_port, args.ft_modbus_port)
    ur_modbus_port, ft_modbus_port = modbus.start()

    # a short GIL switch interval keeps the clock thread on time beside busy handlers
    sys.setswitchinterval(0.0005)
    gc.freeze()
    ticker = threading.Thread(
        target=clock.run_periodic,
        args=(config.period_s, stop, controller.tick, controller.start_host_time),
        name="clock",
        daemon=True,
    )
    ticker.start()

    endpoints = {listener.name: listener.port for listener in listeners}
    print(
        json.dumps(
            {
                "host": args.host,
                "rate_hz": args.rate_hz,
                "controller_version": config.polyscope_version,
                **endpoints,
                "ur_modbus": ur_modbus_port,
                "ft_modbus": ft_modbus_port,
            }
        ),
        flush=True,
    )

    while not stop.wait(0.5):
        pass

    ticker.join(timeout=2.0)
    for listener in listeners:
        listener.close()
    rtde.drop_all()
    modbus.stop()
    if args.trace_file:
        with controller.lock, open(args.trace_file, "w", encoding="utf-8") as stream:
            controller.trace.write_json_lines(stream)
    return 0


if __name__ == "__main__":
    sys.exit(main())
