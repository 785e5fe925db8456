"""The network lab in namespaces (deploy/netlab/netlab.sh; needs root, as the test command
does): a device session crosses it through the impairment relay with the delay asked
for, while the control channel's TCP is routed straight through; the lab is torn down
on exit and when its run is interrupted; bad use is refused by name."""

import json
import os
import pathlib
import signal
import subprocess

import pytest

REPO = pathlib.Path(__file__).resolve().parent.parent
NETLAB = REPO / "deploy" / "netlab" / "netlab.sh"
TOKEN = "netlab-token-0123456789"


def namespaces(name: str) -> list[str]:
    listing = subprocess.run(["ip", "netns", "list"], capture_output=True, text=True, check=True).stdout
    return [line.split()[0] for line in listing.splitlines() if line.startswith(f"hnl-{name}-")]


def netlab(*args: str, **kwargs) -> subprocess.CompletedProcess:
    return subprocess.run(["bash", str(NETLAB), *args], capture_output=True, text=True, timeout=60, **kwargs)


@pytest.fixture
def lab():
    name = f"t{os.getpid() % 100000}"
    up = netlab("up", name, "--devices", "2")
    assert up.returncode == 0, up.stderr
    yield name, json.loads(up.stdout)
    assert netlab("down", name).returncode == 0
    assert namespaces(name) == []


def in_lab(name: str, where: str, *command: str) -> list[str]:
    return ["bash", str(NETLAB), "exec", name, where, "--", *command]


def test_a_session_crosses_the_lab_through_the_relay(bin_dir, lab, tmp_path):
    name, layout = lab
    assert set(namespaces(name)) == {f"hnl-{name}-server", f"hnl-{name}-router", f"hnl-{name}-dev1",
                                     f"hnl-{name}-dev2"}
    server_address = layout["server"]["address"]
    cert, key, token = tmp_path / "cert.pem", tmp_path / "key.pem", tmp_path / "token"
    subprocess.run(["openssl", "req", "-x509", "-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:prime256v1",
                    "-nodes", "-keyout", str(key), "-out", str(cert), "-days", "1", "-subj", f"/CN={server_address}",
                    "-addext", f"subjectAltName=IP:{server_address}"], check=True, capture_output=True, timeout=30)
    token.write_text(TOKEN + "\n")
    server = subprocess.Popen(in_lab(name, "server", str(bin_dir / "hapticd"), "--host", server_address,
                                     "--tls-cert", str(cert), "--tls-key", str(key), "--access-token-file",
                                     str(token), "--log-level", "warning"),
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    relay = subprocess.Popen(in_lab(name, "router", str(bin_dir / "hapticd-netem"), "--listen", "0.0.0.0:9000",
                                    "--forward", f"{server_address}:7461", "--delay-ms", "20", "--loss", "0.02",
                                    "--seed", "3", "--realtime-priority", "0"),
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert json.loads(server.stdout.readline())["udp"] == f"{server_address}:7461"
        assert json.loads(relay.stdout.readline())["listen"] == "0.0.0.0:9000"
        device = layout["devices"][1]  # the second device, through its own link
        run = subprocess.run(in_lab(name, "dev2", str(bin_dir / "hapticd-proxy"), "--server",
                                    f"{server_address}:7460", "--udp-via", f"{device['router']}:9000", "--tls-ca",
                                    str(cert), "--access-token-file", str(token), "--seconds", "2", "--path",
                                    "press", "--realtime-priority", "0"),
                             capture_output=True, text=True, timeout=60)
        assert run.returncode == 0, run.stderr
        report = json.loads(run.stdout)
    finally:
        relay.send_signal(signal.SIGTERM)
        relay_out, relay_err = relay.communicate(timeout=10)
        server.send_signal(signal.SIGTERM)
        server.communicate(timeout=10)
    assert relay.returncode == 0, relay_err
    summary = json.loads(relay_out.strip().splitlines()[-1])
    # 20 ms each way plus the floor of two veth hops and the relay's own error
    assert 40_000 <= report["wire_rtt_p50_us"] <= 55_000
    # every tick sent (or skipped after a stall of the machine), every one reached the relay
    assert summary["flows"] == 1 and summary["up"]["in"] == report["packets_sent"]
    assert report["packets_sent"] + report["skipped_ticks"] == 2000
    lost = summary["up"]["lost"] + summary["down"]["lost"]
    assert 40 <= lost <= 130  # 2% each way of 2000, within 5 standard deviations
    # what the device missed: lost each way, and the 40 ms in flight when it stopped
    assert lost <= report["packets_lost"] <= lost + 45


def test_a_run_is_torn_down_when_interrupted(bin_dir):
    name = f"i{os.getpid() % 100000}"
    # the command says when it runs: the run starts it once the relay is up. SIGINT at
    # its default, as a terminal gives it: a test run started in the background inherits
    # it ignored, and a shell cannot trap a signal ignored on entry
    run = subprocess.Popen(["bash", str(NETLAB), "run", "--name", name, "--delay-ms", "5", "--",
                            "bash", "-c", "echo up; exec sleep 60"],
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                           preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    assert run.stdout.readline().strip() == "up", run.stderr.read()
    assert len(namespaces(name)) == 3
    run.send_signal(signal.SIGINT)
    _, err = run.communicate(timeout=20)
    assert run.returncode == 130
    assert namespaces(name) == []
    # the relay's summary, on the way out
    assert json.loads(err.strip().splitlines()[-1])["flows"] == 0


def test_a_run_passes_its_command_the_lab_and_its_status(bin_dir):
    name = f"s{os.getpid() % 100000}"
    done = netlab("run", "--name", name, "--devices", "3", "--", "bash", "-c",
                  f'echo "$NETLAB_NAME $NETLAB_SERVER $NETLAB_RELAY"; bash {NETLAB} exec "$NETLAB_NAME" dev3 -- '
                  "ip -4 -o addr show dev eth0; exit 7")
    assert done.returncode == 7, done.stderr
    lines = done.stdout.splitlines()
    assert lines[0] == f"{name} 10.77.0.2 10.77.1.1:9000"
    assert "10.77.3.2/24" in lines[1]
    assert namespaces(name) == []


def test_bad_use_is_refused_by_name():
    done = netlab("up", "Bad_Name")
    assert done.returncode == 2 and "NAME is \"Bad_Name\"" in done.stderr
    done = netlab("up", "ok", "--devices", "99")
    assert done.returncode == 2 and "--devices is \"99\"" in done.stderr
    done = netlab("exec", "nolab", "server", "--", "true")
    assert done.returncode == 2 and "no namespace server in lab nolab" in done.stderr
    done = netlab("run", "--name", "bad", "--delay-ms", "-1", "--", "true")
    assert done.returncode == 2 and "the relay did not start" in done.stderr
    assert namespaces("bad") == []
