"""The UR bridge's latency and the arm's lag (issue 15), against the protocol-level
controller simulator (tests/ur_sim) and a real hapticd server:

1. Command latency: from reading the robot's state to commanding the new target
   (servoL), the bridge's own measurement, at 500 Hz (e-Series) and 125 Hz (CB3),
   beside the same loop without the server (ur_rtde read + servoL only, in this process)
   in alternating blocks of the same run: the baseline, so the table shows what the
   filter, the admittance exchange and the limiter add, and both against the period.
2. The arm's lag with the simulated lookahead (0.03, 0.1, 0.2 s): a person pushes 15 N
   sideways; from the simulator's trace, how far the arm trails its servo target in
   time while it moves at a steady speed (a servoj lookahead of 0.03 s trails by 34 ms
   on a real arm, URCL#86), and the time from the push to half the steady speed (the
   whole chain: filter, avatar, limiter, arm).

    .venv/bin/python bench/ur_bridge_latency.py build/bin [--seconds 6] [--blocks 2]

Prints a markdown table on stdout and one JSON line per run on stderr.
"""

from __future__ import annotations

import argparse
import json
import pathlib
import subprocess
import sys
import tempfile
import time

import numpy as np

REPO = pathlib.Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO / "tests"))

from server_process import running_server  # noqa: E402
from ur_sim.launcher import realtime_prefix, rows_of, running_simulator  # noqa: E402

FREE_SCENE = {"scene": {"objects": [{"name": "floor", "shape": {"type": "plane"},
              "position": [0, 0, 0], "material": {"stiffness": 5000}}]}}  # fmt: skip


def run_bridge(sim, server, seconds: float, *flags: str) -> dict:
    command = [*realtime_prefix(), sys.executable, "-m", "hapticd", "ur-bridge", "--robot", sim.host,
               "--server", server.tcp, "--seconds", str(seconds), *flags]  # fmt: skip
    done = subprocess.run(command, capture_output=True, text=True, timeout=seconds + 60)
    if done.returncode != 0:
        raise SystemExit(f"the bridge failed: {done.stderr}")
    return json.loads(done.stdout.strip().splitlines()[-1])


def bare_loop(sim, seconds: float, rate_hz: float) -> dict:
    """The baseline: ur_rtde read + servoL at the rate, nothing between them."""
    import rtde_control
    import rtde_receive

    receive = rtde_receive.RTDEReceiveInterface(sim.host, rate_hz)
    control = rtde_control.RTDEControlInterface(sim.host, rate_hz)
    period = 1.0 / rate_hz
    latency = []
    try:
        pose = receive.getActualTCPPose()
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            cycle = control.initPeriod()
            read_ns = time.monotonic_ns()
            receive.getTimestamp()
            pose = receive.getActualTCPPose()
            receive.getActualTCPForce()
            control.servoL(pose, 0.0, 0.0, period, 0.03, 500)
            latency.append(time.monotonic_ns() - read_ns)
            control.waitPeriod(cycle)
        control.servoStop(10.0)
        control.stopScript()
    finally:
        control.disconnect()
        receive.disconnect()
    us = np.array(latency) / 1e3
    return {"ticks": len(latency), "p50": float(np.percentile(us, 50)), "p99": float(np.percentile(us, 99))}


def latency_part(bin_dir: pathlib.Path, scene: str, seconds: float, blocks: int) -> list[dict]:
    rows = []
    for rate in (500.0, 125.0):
        sim_flags = ["--rate-hz", str(int(rate))]
        bridge_flags = ["--rate-hz", str(int(rate))]
        for block in range(blocks):
            for peer in ("bridge", "bare"):
                with running_simulator(*sim_flags) as sim:
                    if peer == "bare":
                        result = bare_loop(sim, seconds, rate)
                    else:
                        with running_server(bin_dir, "--log-level", "warning", "--scene", scene) as server:
                            sim.ask(cmd="person", spring={"anchor": [0.5, -0.1, 0.3], "k": 200.0})
                            summary = run_bridge(sim, server, seconds, *bridge_flags)
                        result = {"ticks": summary["ticks"], "p50": summary["command_latency_p50_us"],
                                  "p99": summary["command_latency_p99_us"],
                                  "overruns": summary["overruns"], "exit": summary["exit_reason"]}  # fmt: skip
                row = {"part": "latency", "rate_hz": rate, "peer": peer, "block": block, **result}
                print(json.dumps(row), file=sys.stderr)
                rows.append(row)
    return rows


def lag_part(bin_dir: pathlib.Path, scene: str, seconds: float) -> list[dict]:
    rows = []
    for lookahead in (0.03, 0.1, 0.2):
        with (
            running_simulator() as sim,
            running_server(bin_dir, "--log-level", "warning", "--scene", scene) as server,
        ):
            command = [*realtime_prefix(), sys.executable, "-m", "hapticd", "ur-bridge",
                       "--robot", sim.host, "--server", server.tcp, "--seconds", str(seconds),
                       "--lookahead", str(lookahead)]  # fmt: skip
            bridge = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
            deadline = time.monotonic() + 20
            while sim.state()["counters"]["servoL"] < 10 and time.monotonic() < deadline:
                time.sleep(0.05)
            pushed = sim.ask(cmd="ping")["host_time"]
            sim.ask(cmd="person", force=[15, 0, 0])
            out, err = bridge.communicate(timeout=seconds + 60)
            if bridge.returncode != 0:
                raise SystemExit(f"the bridge failed: {err}")
            trace = rows_of(sim.trace(pushed))
        moving = [r for r in trace if r["target"] is not None]
        speeds = np.array([r["vx"] for r in moving])
        steady_speed = float(np.median(speeds[speeds > 0.9 * speeds.max()]))
        steady = [r for r in moving if abs(r["vx"] - steady_speed) < 0.05 * steady_speed]
        trail_ms = float(np.median([(r["target"][0] - r["x"]) / r["vx"] for r in steady])) * 1e3
        half = next(r for r in moving if r["vx"] >= 0.5 * steady_speed)
        row = {"part": "lag", "lookahead_s": lookahead, "steady_speed_m_s": steady_speed,
               "trail_ms": trail_ms, "push_to_half_speed_ms": (half["host_time"] - pushed) * 1e3,
               "steady_rows": len(steady)}  # fmt: skip
        print(json.dumps(row), file=sys.stderr)
        rows.append(row)
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("bin_dir", type=pathlib.Path)
    parser.add_argument("--seconds", type=float, default=6.0)
    parser.add_argument("--blocks", type=int, default=2)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        scene = str(pathlib.Path(tmp) / "floor.json")
        pathlib.Path(scene).write_text(json.dumps(FREE_SCENE))
        latency = latency_part(args.bin_dir, scene, args.seconds, args.blocks)
        lag = lag_part(args.bin_dir, scene, args.seconds)
    out = ["## Command latency: reading the robot to commanding its target (µs)\n",
           "Medians over the blocks of each: *bridge* is `hapticd ur-bridge` (the filter, the "
           "admittance exchange with the server over UDP, the limiter); *bare* the same ur_rtde "
           "read and servoL with nothing between them, in the same run.\n",
           "| rate Hz | period µs | bridge p50 | bridge p99 | bare p50 | bare p99 | bridge p99 / period | overruns |",
           "| ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"]  # fmt: skip
    for rate in (500.0, 125.0):
        mine = [r for r in latency if r["rate_hz"] == rate and r["peer"] == "bridge"]
        bare = [r for r in latency if r["rate_hz"] == rate and r["peer"] == "bare"]
        period = 1e6 / rate

        def med(rows, key):
            return float(np.median([r[key] for r in rows]))

        out.append(f"| {rate:.0f} | {period:.0f} | {med(mine, 'p50'):.0f} | {med(mine, 'p99'):.0f} | "
                   f"{med(bare, 'p50'):.0f} | {med(bare, 'p99'):.0f} | {med(mine, 'p99') / period:.2f} | "
                   f"{sum(r['overruns'] for r in mine)} |")  # fmt: skip
    out += ["\n## The arm's lag with the simulated lookahead (500 Hz, a 15 N push sideways)\n",
            "*trail*: how far behind its servo target the arm is, in time, at a steady speed "
            "(the simulator's first-order lag; a real arm with lookahead 0.03 s trails by 34 ms, "
            "URCL#86); *push to half speed*: from the push to half the steady speed, the whole "
            "chain (force filter, avatar, the limiter's 1 m/s² ramp, the arm).\n",
            "| lookahead s | steady speed m/s | trail ms | push to half speed ms |",
            "| ---: | ---: | ---: | ---: |"]  # fmt: skip
    for r in lag:
        out.append(f"| {r['lookahead_s']:.2f} | {r['steady_speed_m_s']:.3f} | {r['trail_ms']:.1f} | "
                   f"{r['push_to_half_speed_ms']:.0f} |")  # fmt: skip
    print("\n".join(out))


if __name__ == "__main__":
    main()
