"""The latency benchmark of the network lab (issue 13), in one run on this machine:

1. layers: the device-to-command round trip of hapticd-proxy against hapticd over
   loopback, over veth between network namespaces (deploy/netlab/netlab.sh: device,
   router, server) and between two podman containers, each beside a plain UDP echo
   (hapticd-udp-echo) between the same two endpoints, in alternating blocks; what each
   layer adds over loopback;
2. impairment, the real UDP path: the proxy's simulated hand stroking the default scene
   through hapticd-netem on loopback, over a grid of one-way delay, jitter and loss: the
   round trip, packets lost and late, and what the force loop does today (the net energy
   the rendered force put into the device, how deep the handle went below the floor, the
   largest force, the ticks in contact), against the grid's no-delay run;
3. impairment, the simulated device: hapticd-sim (deterministic; its channel model) on
   a wall pressed by the scenario format's hand, over the same delays and losses, for
   penalty and the god-object;
4. rendering across delay, through the namespace topology: the proxy in dev1 presses the
   simulated hand into a 5000 N/m box on the server, its datagrams through hapticd-netem
   in the router, for each way of rendering (direct: the device renders the commands'
   force; local-model: the device renders from the local models of the scene the
   commands carry; each also with two-port passivity, --tdpa, and with a 10% perceptual
   deadband, --deadband 0.1) over a grid of delay, jitter and loss: the net energy, the
   channel's energy as its two ports measured it, the steady force's error against the
   wall's k * d, how far the avatar went into the box, the models taken, and the messages
   each way per tick.

Percentiles are exact order statistics over every sample the proxy kept (none dropped).

    container_latency.py BIN_DIR OUT_DIR [--blocks 3] [--block-seconds 3] [--grid-seconds 3]
        [--press-seconds 4] [--parts layers,udp,sim,remote]
        -> OUT_DIR/container_latency.{md,csv,png} and raw/container_latency.jsonl

--parts runs only the parts named; the others' rows are read back from the last run's
raw/container_latency.jsonl (and the Markdown says which run they come from).
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import pathlib
import re
import signal
import statistics
import subprocess
import tempfile
import time

REPO = pathlib.Path(__file__).resolve().parents[1]
NETLAB = REPO / "deploy" / "netlab" / "netlab.sh"
IMAGE = "localhost/hapticd:latest"
PODMAN_ENV = {**os.environ, "CONTAINERS_CONF": str(REPO / "deploy" / "containers" / "containers.conf")}
QUANTILES = ("p50", "p99", "p999", "max")
DELAYS_MS = (0, 1, 5, 20, 50, 100)
LOSSES = (0.0, 0.05, 0.2)
JITTERED = ((5, 2), (20, 5))  # (delay, jitter) ms, no loss
# part 4: (one-way delay ms, jitter ms, loss) each way, and the box pressed
REMOTE_CELLS = ((0, 0, 0.0), (5, 1, 0.0), (20, 5, 0.05), (50, 5, 0.1), (50, 20, 0.1), (100, 10, 0.1), (250, 20, 0.2))
# part 4: the ways of rendering, and the proxy's flags for each
REMOTE_MODES = (
    ("direct", ["--remote-mode", "direct"]),
    ("direct + TDPA", ["--remote-mode", "direct", "--tdpa"]),
    ("direct + deadband 10%", ["--remote-mode", "direct", "--deadband", "0.1"]),
    ("local-model", ["--remote-mode", "local-model"]),
    ("local-model + TDPA", ["--remote-mode", "local-model", "--tdpa"]),
    ("local-model + deadband 10%", ["--remote-mode", "local-model", "--deadband", "0.1"]),
)
PARTS = {"layers": "layers", "udp": "udp grid", "sim": "sim grid", "remote": "remote grid"}
BOX_STIFFNESS = 5000.0
BOX_TOP = 0.1
PRESS_PATH = "0,0,0,0.12;1,0,0,0.09;4,0,0,0.09"  # 2 cm above the top to 1 cm into it, held


def wire(report: dict) -> dict[str, float]:
    return {q: report[f"wire_rtt_{q}_us"] for q in QUANTILES}


class Process:
    """A started process whose first stdout line is JSON; stopped with SIGTERM."""

    def __init__(self, command: list[str], env=None) -> None:
        self.process = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
        self.start = json.loads(self.process.stdout.readline())

    def stop(self) -> str:
        self.process.send_signal(signal.SIGTERM)
        out, _ = self.process.communicate(timeout=20)
        return out


def run_json(command: list[str], env=None, timeout: float = 120) -> dict:
    done = subprocess.run(command, capture_output=True, text=True, timeout=timeout, env=env)
    if done.returncode != 0:
        raise RuntimeError(f"{command[:6]}... failed: {done.stderr[-2000:]}")
    return json.loads([line for line in done.stdout.splitlines() if line.startswith("{")][-1])


def make_secrets(directory: pathlib.Path, address: str) -> None:
    directory.mkdir(parents=True, exist_ok=True)
    subprocess.run(["openssl", "req", "-x509", "-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:prime256v1", "-nodes",
                    "-keyout", str(directory / "key.pem"), "-out", str(directory / "cert.pem"), "-days", "1",
                    "-subj", "/CN=server", "-addext", f"subjectAltName=DNS:server,IP:{address}"],
                   check=True, capture_output=True, timeout=30)
    (directory / "token").write_text("bench-token-0123456789abcdef\n")
    for name in ("key.pem", "cert.pem", "token"):
        (directory / name).chmod(0o644)


def layers(bin_dir: pathlib.Path, blocks: int, seconds: float, log) -> list[dict]:
    rows = []
    tls = ["--tls-ca", "{s}/cert.pem", "--access-token-file", "{s}/token"]
    with tempfile.TemporaryDirectory() as scratch:
        secrets = pathlib.Path(scratch) / "secrets"
        make_secrets(secrets, "10.77.0.2")
        proxy_args = ["--seconds", str(seconds), "--path", "press", "--budget-us", "900"]

        # loopback
        server = Process([str(bin_dir / "hapticd"), "--tcp-port", "0", "--udp-port", "0", "--log-level", "warning"])
        echo = Process([str(bin_dir / "hapticd-udp-echo")])
        try:
            for block in range(1, blocks + 1):
                for peer, target in (("hapticd", ["--server", server.start["tcp"]]),
                                     ("echo", ["--echo", echo.start["udp"]])):
                    report = run_json([str(bin_dir / "hapticd-proxy"), *target, *proxy_args])
                    rows.append({"layer": "loopback", "block": block, "peer": peer, **wire(report),
                                 "lost": report["packets_lost"]})
                    log({"part": "layers", **rows[-1], "proxy": report})
        finally:
            server.stop()
            echo.stop()

        # namespaces: the device in dev1, the server (and the echo) in server, the router between
        name = f"b{os.getpid() % 100000}"
        subprocess.run(["bash", str(NETLAB), "up", name], check=True, capture_output=True, timeout=60)
        exec_in = lambda where, *command: ["bash", str(NETLAB), "exec", name, where, "--", *command]  # noqa: E731
        try:
            server = Process(exec_in("server", str(bin_dir / "hapticd"), "--host", "10.77.0.2", "--tls-cert",
                                     f"{secrets}/cert.pem", "--tls-key", f"{secrets}/key.pem", "--access-token-file",
                                     f"{secrets}/token", "--log-level", "warning"))
            echo = Process(exec_in("server", str(bin_dir / "hapticd-udp-echo"), "--host", "10.77.0.2",
                                   "--port", "7470"))
            try:
                for block in range(1, blocks + 1):
                    for peer, target in (("hapticd", ["--server", "10.77.0.2:7460",
                                                      *[a.format(s=secrets) for a in tls]]),
                                         ("echo", ["--echo", "10.77.0.2:7470"])):
                        report = run_json(exec_in("dev1", str(bin_dir / "hapticd-proxy"), *target, *proxy_args))
                        rows.append({"layer": "namespaces (veth, router)", "block": block, "peer": peer,
                                     **wire(report), "lost": report["packets_lost"]})
                        log({"part": "layers", **rows[-1], "proxy": report})
            finally:
                server.stop()
                echo.stop()
        finally:
            subprocess.run(["bash", str(NETLAB), "down", name], capture_output=True, timeout=60)

        # containers: server and echo in two containers, the proxy in a third, one podman network
        network = f"bench-{os.getpid()}"
        podman = lambda *args: subprocess.run(["podman", *args], capture_output=True, text=True,  # noqa: E731
                                               env=PODMAN_ENV, timeout=120)
        podman("network", "create", network)
        try:
            podman("run", "-d", "--name", f"{network}-server", "--network", network, "--network-alias", "server", "-v",
                   f"{secrets}:/secrets:ro", IMAGE, "--host", "0.0.0.0", "--tls-cert", "/secrets/cert.pem",
                   "--tls-key", "/secrets/key.pem", "--access-token-file", "/secrets/token", "--log-level", "warning")
            podman("run", "-d", "--name", f"{network}-echo", "--network", network, "--network-alias", "echo",
                   "--entrypoint", "hapticd-udp-echo", IMAGE, "--host", "0.0.0.0", "--port", "7470")
            time.sleep(1.5)
            device = ["podman", "run", "--rm", "--network", network, "-v", f"{secrets}:/secrets:ro",
                      "--entrypoint", "hapticd-proxy", IMAGE]
            for block in range(1, blocks + 1):
                for peer, target in (("hapticd", ["--server", "server:7460", *[a.format(s="/secrets") for a in tls]]),
                                     ("echo", ["--echo", "echo:7470"])):
                    report = run_json([*device, *target, *proxy_args], env=PODMAN_ENV)
                    rows.append({"layer": "containers (podman network)", "block": block, "peer": peer,
                                 **wire(report), "lost": report["packets_lost"]})
                    log({"part": "layers", **rows[-1], "proxy": report})
        finally:
            podman("rm", "-f", f"{network}-server", f"{network}-echo")
            podman("network", "rm", network)
    return rows


def udp_grid(bin_dir: pathlib.Path, seconds: float, log) -> list[dict]:
    rows = []
    cells = [(d, 0.0, loss) for d in DELAYS_MS for loss in LOSSES] + [(d, j, 0.0) for d, j in JITTERED]
    server = Process([str(bin_dir / "hapticd"), "--tcp-port", "0", "--udp-port", "0", "--log-level", "warning"])
    try:
        for delay, jitter, loss in cells:
            relay = Process([str(bin_dir / "hapticd-netem"), "--listen", "127.0.0.1:0", "--forward",
                             server.start["udp"], "--delay-ms", str(delay), "--jitter-ms", str(jitter), "--loss",
                             str(loss), "--seed", "1"])
            try:
                report = run_json([str(bin_dir / "hapticd-proxy"), "--server", server.start["tcp"], "--udp-via",
                                   relay.start["listen"], "--seconds", str(seconds), "--path", "stroke"])
            finally:
                summary = json.loads(relay.stop().strip().splitlines()[-1])
            rows.append({"delay_ms": delay, "jitter_ms": jitter, "loss": loss, **wire(report),
                         "sent": report["packets_sent"], "answered": report["packets_answered"],
                         "late": report["packets_late"], "lost": report["packets_lost"],
                         "relay_lost": summary["up"]["lost"] + summary["down"]["lost"],
                         "energy_j": report["energy_j"], "penetration_mm": max(0.0, -1000 * report["lowest_z_m"]),
                         "max_force_n": report["max_force_n"], "contacts": report["contacts"],
                         "watchdog_trips": report["watchdog_trips"]})
            log({"part": "udp grid", **rows[-1], "proxy": report, "relay": summary})
    finally:
        server.stop()
    return rows


def sim_grid(bin_dir: pathlib.Path, log) -> list[dict]:
    rows = []
    scenario = REPO / "bench" / "scenarios" / "press_box.json"
    for method in ("penalty", "god_object"):
        for delay in (0, 1, 2, 5, 10, 20, 50, 100):
            for loss in LOSSES:
                summary = run_json([str(bin_dir / "hapticd-sim"), str(scenario), "--set", f"avatar.method={method}",
                                    "--set", f"channel.delay_ms={delay}", "--set", f"channel.loss={loss}",
                                    "--set", "duration_s=4"])
                rows.append({"method": method, "delay_ms": delay, "loss": loss, "energy_j": summary["energy_j"],
                             "penetration_mm": 1000 * summary["max_penetration_m"],
                             "max_force_n": summary["max_force_n"], "contact_ticks": summary["contact_ticks"],
                             "ticks": summary["ticks"]})
                log({"part": "sim grid", **rows[-1]})
    return rows


def remote_grid(bin_dir: pathlib.Path, seconds: float, log) -> list[dict]:
    rows = []
    with tempfile.TemporaryDirectory() as scratch:
        secrets = pathlib.Path(scratch) / "secrets"
        make_secrets(secrets, "10.77.0.2")
        scene = pathlib.Path(scratch) / "box.json"
        scene.write_text(json.dumps({"scene": {"objects": [{
            "name": "box", "shape": {"type": "box", "half_extents": [0.05, 0.05, 0.05]},
            "position": [0, 0, BOX_TOP / 2], "material": {"stiffness": BOX_STIFFNESS}}]}}))
        scene.chmod(0o644)
        name = f"r{os.getpid() % 100000}"
        subprocess.run(["bash", str(NETLAB), "up", name], check=True, capture_output=True, timeout=60)
        exec_in = lambda where, *command: ["bash", str(NETLAB), "exec", name, where, "--", *command]  # noqa: E731
        try:
            server = Process(exec_in("server", str(bin_dir / "hapticd"), "--host", "10.77.0.2", "--scene", str(scene),
                                     "--tls-cert", f"{secrets}/cert.pem", "--tls-key", f"{secrets}/key.pem",
                                     "--access-token-file", f"{secrets}/token", "--log-level", "warning"))
            try:
                for delay, jitter, loss in REMOTE_CELLS:
                    for mode, flags in REMOTE_MODES:
                        relay = Process(exec_in("router", str(bin_dir / "hapticd-netem"), "--listen", "10.77.1.1:9000",
                                                "--forward", "10.77.0.2:7461", "--delay-ms", str(delay),
                                                "--jitter-ms", str(jitter), "--loss", str(loss), "--seed", "1"))
                        try:
                            report = run_json(exec_in(
                                "dev1", str(bin_dir / "hapticd-proxy"), "--server", "10.77.0.2:7460", "--tls-ca",
                                f"{secrets}/cert.pem", "--access-token-file", f"{secrets}/token", "--udp-via",
                                "10.77.1.1:9000", "--seconds", str(seconds), "--path", PRESS_PATH, *flags))
                        finally:
                            summary = json.loads(relay.stop().strip().splitlines()[-1])
                        depth = BOX_TOP - report["final_position_m"][2]
                        wall = BOX_STIFFNESS * depth
                        rows.append({"mode": mode, "delay_ms": delay, "jitter_ms": jitter, "loss": loss, **wire(report),
                                     "lost": report["packets_lost"], "energy_j": report["energy_j"],
                                     "depth_mm": 1000 * depth,
                                     "force_error": (report["final_force_n"][2] - wall) / wall if depth > 0 else None,
                                     "avatar_in_mm": max(0.0, 1000 * (BOX_TOP - report["lowest_avatar_z_m"])),
                                     "max_force_n": report["max_force_n"], "models": report["models_adopted"],
                                     "fragments": report["model_fragments"],
                                     "channel_energy_j": report["channel_energy_j"],
                                     # messages per tick each way: states the device sent, commands
                                     # the server sent (its count, the newest command's number)
                                     "up_per_tick": report["packets_sent"] / report["ticks"],
                                     "down_per_tick": report["server_commands_sent"] / report["ticks"]})
                        log({"part": "remote grid", **rows[-1], "proxy": report, "relay": summary})
            finally:
                server.stop()
        finally:
            subprocess.run(["bash", str(NETLAB), "down", name], capture_output=True, timeout=60)
    return rows


def chart(layer_rows, udp_rows, sim_rows, path: pathlib.Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    figure, axes = plt.subplots(1, 3, figsize=(16, 4.8))
    ax = axes[0]
    for layer in dict.fromkeys(r["layer"] for r in layer_rows):
        for peer, style in (("hapticd", "-"), ("echo", "--")):
            values = [statistics.median(r[q] for r in layer_rows if r["layer"] == layer and r["peer"] == peer)
                      for q in QUANTILES]
            ax.plot(range(len(QUANTILES)), values, style, marker="o", label=f"{layer}, {peer}")
    ax.set_xticks(range(len(QUANTILES)), ["p50", "p99", "p99.9", "max"])
    ax.set_yscale("log")
    ax.set_ylabel("round trip (µs)")
    ax.set_title("Round-trip quantiles by layer (median over blocks)")
    ax.legend(fontsize=7)
    ax = axes[1]
    for loss in LOSSES:
        cells = [r for r in udp_rows if r["loss"] == loss and r["jitter_ms"] == 0]
        ax.plot([r["delay_ms"] for r in cells], [r["energy_j"] for r in cells], marker="o", label=f"loss {loss:.0%}")
    ax.set_xscale("symlog", linthresh=1)
    ax.set_xlabel("one-way delay (ms)")
    ax.set_ylabel("net energy into the device (J)")
    ax.set_title("Real UDP path: the stroke through hapticd-netem")
    ax.legend(fontsize=8)
    ax = axes[2]
    for method, marker in (("penalty", "o"), ("god_object", "s")):
        for loss in (0.0, 0.2):
            cells = [r for r in sim_rows if r["method"] == method and r["loss"] == loss]
            ax.plot([r["delay_ms"] for r in cells], [r["energy_j"] for r in cells], marker=marker,
                    label=f"{method}, loss {loss:.0%}")
    ax.set_xscale("symlog", linthresh=1)
    ax.set_xlabel("one-way delay (ms)")
    ax.set_ylabel("net energy into the device (J)")
    ax.set_title("Simulated device (hapticd-sim, press_box)")
    ax.legend(fontsize=8)
    figure.tight_layout()
    figure.savefig(path, dpi=110)


def describe_run() -> str:
    """This run, as the Markdown's header says it: date, CPUs, load before it."""
    model = next((line.split(":", 1)[1].strip() for line in pathlib.Path("/proc/cpuinfo").read_text().splitlines()
                  if line.startswith("model name")), "unknown CPU")
    load = " ".join(pathlib.Path("/proc/loadavg").read_text().split()[:3])
    return f"{time.strftime('%Y-%m-%d', time.gmtime())}, {os.cpu_count()} CPUs ({model}), load {load}"


def earlier_rows(raw_path: pathlib.Path, md_path: pathlib.Path, parts: set[str]) -> tuple[dict, list, dict]:
    """The rows of the parts not in parts, as the last run logged them, their raw
    records to log again, and which run each part came from (a record's "run", else
    the header of the Markdown that run wrote)."""
    rows: dict[str, list[dict]] = {name: [] for name in PARTS.values()}
    records = []
    header = "an earlier run"
    if md_path.is_file():
        lines = md_path.read_text().splitlines()
        for i, line in enumerate(lines):
            if line[:4].isdigit() and line[4:5] == "-" and i + 1 < len(lines):
                found = re.search(r"load average before the run: ([0-9. ]+?)\.(?: |$)", lines[i + 1])
                load = f"load {found.group(1)}" if found else "load unknown"
                header = f"{line.rstrip(',')}, {load}"
                break
    runs: dict[str, str] = {}
    if raw_path.is_file():
        for line in raw_path.read_text().splitlines():
            record = json.loads(line)
            if record["part"] in parts:
                continue
            record.setdefault("run", header)
            records.append(record)
            runs.setdefault(record["part"], record["run"])
            rows[record["part"]].append({k: v for k, v in record.items()
                                         if k not in ("part", "proxy", "relay", "run")})
    return rows, records, runs


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("bin_dir", type=pathlib.Path)
    parser.add_argument("out_dir", type=pathlib.Path)
    parser.add_argument("--blocks", type=int, default=3)
    parser.add_argument("--block-seconds", type=float, default=3)
    parser.add_argument("--grid-seconds", type=float, default=3)
    parser.add_argument("--press-seconds", type=float, default=4)
    parser.add_argument("--parts", default=",".join(PARTS), help="comma-separated: " + ", ".join(PARTS))
    args = parser.parse_args()
    wanted = args.parts.split(",")
    if not wanted or any(part not in PARTS for part in wanted):
        parser.error(f"--parts is {args.parts!r}; name some of {', '.join(PARTS)}")
    parts = {PARTS[part] for part in wanted}
    raw_path = args.out_dir / "raw" / "container_latency.jsonl"
    kept, records, runs = earlier_rows(raw_path, args.out_dir / "container_latency.md", parts)
    raw = raw_path.open("w")
    for record in records:
        print(json.dumps(record), file=raw, flush=True)
    this_run = describe_run()
    log = lambda record: print(json.dumps({**record, "run": this_run}), file=raw, flush=True)  # noqa: E731

    layer_rows = layers(args.bin_dir, args.blocks, args.block_seconds, log) if "layers" in parts else kept["layers"]
    udp_rows = udp_grid(args.bin_dir, args.grid_seconds, log) if "udp grid" in parts else kept["udp grid"]
    sim_rows = sim_grid(args.bin_dir, log) if "sim grid" in parts else kept["sim grid"]
    remote_rows = (remote_grid(args.bin_dir, args.press_seconds, log) if "remote grid" in parts
                   else kept["remote grid"])

    with (args.out_dir / "container_latency.csv").open("w", newline="") as out:
        writer = csv.writer(out)
        writer.writerow(["part", "setting", "delay_ms", "jitter_ms", "loss", *QUANTILES, "lost", "energy_j",
                         "penetration_mm", "max_force_n", "contacts", "channel_energy_j", "up_per_tick",
                         "down_per_tick"])
        for r in layer_rows:
            writer.writerow(["layers", f"{r['layer']} / {r['peer']} / block {r['block']}", "", "", "",
                             *[r[q] for q in QUANTILES], r["lost"], "", "", "", ""])
        for r in udp_rows:
            writer.writerow(["udp grid", "stroke", r["delay_ms"], r["jitter_ms"], r["loss"], *[r[q] for q in QUANTILES],
                             r["lost"], r["energy_j"], r["penetration_mm"], r["max_force_n"], r["contacts"]])
        for r in sim_rows:
            writer.writerow(["sim grid", r["method"], r["delay_ms"], 0, r["loss"], "", "", "", "", "", "",
                             r["energy_j"], r["penetration_mm"], r["max_force_n"], r["contact_ticks"]])
        for r in remote_rows:
            writer.writerow(["remote grid", r["mode"], r["delay_ms"], r["jitter_ms"], r["loss"],
                             *[r[q] for q in QUANTILES], r["lost"], r["energy_j"], r["avatar_in_mm"],
                             r["max_force_n"], "", r.get("channel_energy_j", ""), r.get("up_per_tick", ""),
                             r.get("down_per_tick", "")])
    chart(layer_rows, udp_rows, sim_rows, args.out_dir / "container_latency.png")

    md = []
    reused = [name for name in PARTS.values() if name not in parts]
    if reused:
        md.append(f"This run ({this_run}): {', '.join(name for name in PARTS.values() if name in parts)}. "
                  "Read back from raw/container_latency.jsonl: " +
                  "; ".join(f"{name} from the run of {runs.get(name, 'an earlier run')}" for name in reused) + ".\n")
    md.append("## Layers: hapticd against a plain UDP echo between the same endpoints\n")
    md.append(f"hapticd-proxy at 1 kHz (a handle held 2 mm into the floor: every tick in contact), {args.blocks} "
              f"blocks of {args.block_seconds:g} s per peer, hapticd and the echo in turn; wire round trips "
              "(send to the kernel's arrival stamp), medians over the blocks, µs. *Added by the layer*: its "
              "echo's quantile less loopback's echo's (the network's own cost); *hapticd over echo*: the "
              "server's cost on that layer.\n")
    md.append("| layer | peer | p50 | p99 | p99.9 | max | lost |")
    md.append("| --- | --- | ---: | ---: | ---: | ---: | ---: |")
    medians = {}
    for layer in dict.fromkeys(r["layer"] for r in layer_rows):
        for peer in ("hapticd", "echo"):
            cells = [r for r in layer_rows if r["layer"] == layer and r["peer"] == peer]
            medians[layer, peer] = {q: statistics.median(r[q] for r in cells) for q in QUANTILES}
            m = medians[layer, peer]
            md.append(f"| {layer} | {peer} | {m['p50']:.1f} | {m['p99']:.1f} | {m['p999']:.1f} | "
                      f"{m['max']:.1f} | {sum(r['lost'] for r in cells)} |")
    md.append("\n| layer | added by the layer p50 / p99 µs | hapticd over echo p50 / p99 µs |")
    md.append("| --- | ---: | ---: |")
    for layer in dict.fromkeys(r["layer"] for r in layer_rows):
        e, l0, h = medians[layer, "echo"], medians["loopback", "echo"], medians[layer, "hapticd"]
        md.append(f"| {layer} | {e['p50'] - l0['p50']:.1f} / {e['p99'] - l0['p99']:.1f} | "
                  f"{h['p50'] - e['p50']:.1f} / {h['p99'] - e['p99']:.1f} |")
    md.append("\n## Impairment, the real UDP path: today's rendering across a delayed channel\n")
    md.append(f"The proxy's simulated hand strokes the default scene ({args.grid_seconds:g} s: press 5 mm into the "
              "floor, slide into the box, lift) through hapticd-netem on loopback. *energy*: the net work the "
              "rendered force did on the handle (positive: the loop generated energy); *below floor*: how deep the "
              "handle went under z = 0; *late*: commands that came after their tick's 500 µs budget (the proxy "
              "renders the newest command that came, late or not; its watchdog holds it 50 ms, then ramps the "
              "force to zero).\n")
    md.append("| delay ms (each way) | jitter ms | loss | rtt p50 µs | rtt p99 µs | rtt max µs | late | lost | "
              "energy J | below floor mm | max force N | contacts | watchdog trips |")
    md.append("| ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |")
    for r in udp_rows:
        md.append(f"| {r['delay_ms']} | {r['jitter_ms']} | {r['loss']:.0%} | {r['p50']:.0f} | {r['p99']:.0f} | "
                  f"{r['max']:.0f} | {r['late']} | {r['lost']} | {r['energy_j']:+.4f} | {r['penetration_mm']:.2f} | "
                  f"{r['max_force_n']:.2f} | {r['contacts']} | {r['watchdog_trips']} |")
    md.append("\n## Impairment, the simulated device: hapticd-sim on press_box, 4 s\n")
    md.append("The scenario format's hand pushes a point into a 2000 N/m box through the simulator's channel (the "
              "same delay and loss both ways); the renderer's force arrives delayed and is rendered as it arrives "
              "(`remote` mode `direct`).\n")
    md.append("| method | delay ms | loss | energy J | penetration mm | max force N | contact ticks |")
    md.append("| --- | ---: | ---: | ---: | ---: | ---: | ---: |")
    for r in sim_rows:
        md.append(f"| {r['method']} | {r['delay_ms']} | {r['loss']:.0%} | {r['energy_j']:+.4f} | "
                  f"{r['penetration_mm']:.2f} | {r['max_force_n']:.2f} | {r['contact_ticks']} |")
    md.append("\n## Rendering across delay, through the namespace topology: direct, the local model, TDPA, deadband\n")
    md.append(f"hapticd-proxy in dev1 presses the simulated hand into a {BOX_STIFFNESS:g} N/m box on the server "
              f"({args.press_seconds:g} s: from 2 cm above its top to 1 cm into it over 1 s, then held), its datagrams "
              "through hapticd-netem in the router (the delay, jitter and loss each way; TLS control channel). "
              "*direct*: the device renders each command's force as it comes; *local-model*: the device renders "
              "the box itself from the local models the commands carry; *+ TDPA*: two-port time-domain passivity "
              "across the channel (`--tdpa`); *+ deadband 10%*: perceptual deadband coding (`--deadband 0.1`, "
              "keep-alive 10 ms). *energy*: the net work the rendered force did on the handle (positive: "
              "active); *channel J*: the channel's net energy as its two ports measured it (the proxy's view: "
              "its own end and the newest the server reported); *force error*: the last force against the "
              "wall's k·d at the handle's last depth (steady when small); *avatar in*: how far the avatar (proxy) "
              "went into the box; *up, down*: messages per tick, states the device sent and commands the server "
              "sent.\n")
    md.append("| mode | delay ms | jitter ms | loss | rtt p50 µs | lost | energy J | channel J | depth mm | "
              "force error | avatar in mm | max force N | models | up | down |")
    md.append("| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | "
              "---: | ---: |")
    for r in remote_rows:
        error = "n/a" if r["force_error"] is None else f"{r['force_error']:+.2%}"
        channel = f"{r['channel_energy_j']:+.4f}" if "channel_energy_j" in r else "n/a"
        up = f"{r['up_per_tick']:.2f}" if "up_per_tick" in r else "n/a"
        down = f"{r['down_per_tick']:.2f}" if "down_per_tick" in r else "n/a"
        md.append(f"| {r['mode']} | {r['delay_ms']} | {r['jitter_ms']} | {r['loss']:.0%} | {r['p50']:.0f} | "
                  f"{r['lost']} | {r['energy_j']:+.4f} | {channel} | {r['depth_mm']:.3f} | {error} | "
                  f"{r['avatar_in_mm']:.3f} | {r['max_force_n']:.2f} | {r['models']} | {up} | {down} |")
    print("\n".join(md))


if __name__ == "__main__":
    main()
