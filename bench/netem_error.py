"""The impairment relay's own error, measured from outside: the round trip of
hapticd-proxy --echo against a plain UDP echo (hapticd-udp-echo) straight, through
hapticd-netem with no impairment, and through it with a delay each way, in alternating
blocks of the same run. What the relay adds beyond what it was asked for is the through
round trip, less twice the delay asked for, less the straight round trip of the same
block, percentile by percentile (the proxy keeps every sample: no tail is dropped).

    netem_error.py BIN_DIR [--blocks 5] [--block-seconds 4] [--delay-ms 25]
        -> a Markdown section on stdout, the runs as JSON lines on stderr
"""

from __future__ import annotations

import argparse
import json
import pathlib
import signal
import statistics
import subprocess
import sys

PERCENTILES = ("p50", "p99", "p999", "max")


def start(command: list[str]) -> tuple[subprocess.Popen, dict]:
    process = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    return process, json.loads(process.stdout.readline())


def stop(process: subprocess.Popen) -> str:
    process.send_signal(signal.SIGTERM)
    out, _ = process.communicate(timeout=20)
    return out


def proxy(bin_dir: pathlib.Path, target: str, seconds: float) -> dict:
    run = subprocess.run([str(bin_dir / "hapticd-proxy"), "--echo", target, "--seconds", str(seconds),
                          "--budget-us", "900"], capture_output=True, text=True, timeout=seconds + 60, check=True)
    return json.loads(run.stdout)


def wire(report: dict) -> dict[str, float]:
    return {p: report[f"wire_rtt_{p}_us"] for p in PERCENTILES}


def SETTINGS(delay_ms: float):
    """(name, delay each way or None for straight, the relay's extra flags)."""
    return (("straight", None, []), ("relay, no delay", 0.0, []), ("relay, delay", delay_ms, []),
            ("relay, delay, --spin-us 100", delay_ms, ["--spin-us", "100"]))


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("bin_dir", type=pathlib.Path)
    parser.add_argument("--blocks", type=int, default=5)
    parser.add_argument("--block-seconds", type=float, default=4)
    parser.add_argument("--delay-ms", type=float, default=25)
    args = parser.parse_args()

    echo, echo_start = start([str(args.bin_dir / "hapticd-udp-echo")])
    rows = []
    try:
        for block in range(1, args.blocks + 1):
            row = {"block": block}
            for setting, delay, extra in SETTINGS(args.delay_ms):
                if delay is None:
                    report = proxy(args.bin_dir, echo_start["udp"], args.block_seconds)
                    summary = None
                else:
                    relay, relay_start = start([str(args.bin_dir / "hapticd-netem"), "--listen", "127.0.0.1:0",
                                                "--forward", echo_start["udp"], "--delay-ms", str(delay), *extra])
                    try:
                        report = proxy(args.bin_dir, relay_start["listen"], args.block_seconds)
                    finally:
                        summary = json.loads(stop(relay).strip().splitlines()[-1])
                row[setting] = {"wire": wire(report), "lost": report["packets_lost"], "relay": summary}
                print(json.dumps({"block": block, "setting": setting, "proxy": report, "relay": summary}),
                      file=sys.stderr)
            rows.append(row)
    finally:
        stop(echo)

    asked_us = 2000 * args.delay_ms
    print(f"Round trips of hapticd-proxy --echo at 1 kHz against hapticd-udp-echo on loopback (wire: to the "
          f"kernel's arrival stamp), {args.blocks} blocks of {args.block_seconds:g} s, the settings in turn "
          f"in each block; the relay asked for {args.delay_ms:g} ms each way ({asked_us / 1000:g} ms a round "
          "trip). *Added* = through the relay, less the delay asked for, less straight, in the same block.\n")
    print("| block | setting | p50 µs | p99 µs | p99.9 µs | max µs | lost | relay late p99 µs (up / down) |")
    print("| ---: | --- | ---: | ---: | ---: | ---: | ---: | ---: |")
    for row in rows:
        for setting, _, _ in SETTINGS(args.delay_ms):
            cell = row[setting]
            late = "-"
            if cell["relay"]:
                late = (f"{cell['relay']['up']['late_ms']['p99'] * 1000:.0f} / "
                        f"{cell['relay']['down']['late_ms']['p99'] * 1000:.0f}")
            w = cell["wire"]
            print(f"| {row['block']} | {setting} | {w['p50']:.1f} | {w['p99']:.1f} | {w['p999']:.1f} | "
                  f"{w['max']:.1f} | {cell['lost']} | {late} |")
    print()
    print("| added by the relay (median over blocks) | p50 µs | p99 µs | p99.9 µs | max µs |")
    print("| --- | ---: | ---: | ---: | ---: |")
    for setting, delay, _ in SETTINGS(args.delay_ms)[1:]:
        asked = 2000 * delay
        added = {p: statistics.median(row[setting]["wire"][p] - asked - row["straight"]["wire"][p] for row in rows)
                 for p in PERCENTILES}
        print(f"| {setting} | {added['p50']:.1f} | {added['p99']:.1f} | {added['p999']:.1f} | {added['max']:.1f} |")


if __name__ == "__main__":
    main()
