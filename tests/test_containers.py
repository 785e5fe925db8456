"""hapticd in real containers (podman with runc, deploy/containers.sh; root): the image
builds (cached after the first time), a device session from one container reaches the
server in another, the compose file's three services (server, relay, device) run a
session across the relay's delay, and the Kubernetes Deployment plays as a pod
(podman kube play) that serves a device session with its ConfigMap scene and Secret."""

import json
import os
import pathlib
import subprocess
import time

import pytest

# the first test builds the image: minutes on a fresh machine (README), more while the
# machine is busy, beyond pytest.ini's 600 s per test
pytestmark = pytest.mark.timeout(1800)

REPO = pathlib.Path(__file__).resolve().parent.parent
IMAGE = "localhost/hapticd:latest"
ENV = {**os.environ, "CONTAINERS_CONF": str(REPO / "deploy" / "containers" / "containers.conf")}


def podman(*args: str, check: bool = True, timeout: float = 120) -> subprocess.CompletedProcess:
    return subprocess.run(["podman", *args], capture_output=True, text=True, timeout=timeout, check=check, env=ENV)


@pytest.fixture(scope="module")
def image():
    # the first build on a machine takes minutes (README); later ones reuse the layers
    built = subprocess.run(["bash", str(REPO / "deploy" / "containers.sh")], capture_output=True, text=True,
                           timeout=1800)
    assert built.returncode == 0, built.stderr
    return IMAGE


@pytest.fixture
def secrets(tmp_path):
    directory = tmp_path / "secrets"
    subprocess.run(["bash", str(REPO / "deploy" / "containers" / "make_secrets.sh"), str(directory)], check=True,
                   timeout=60)
    return directory


def proxy_report(logs: str) -> dict:
    return json.loads([line for line in logs.splitlines() if line.startswith("{\"target\"")][-1])


def assert_served(report: dict, ticks: int) -> None:
    """Every tick run sent its packet (a tick skipped after a stall of the machine is
    counted), none lost on the unimpaired path, each answered in time or late; most in
    time (how many is the machine's load: bench/ measures it), and the press felt."""
    sent = report["packets_sent"]
    assert sent == report["ticks"] and sent + report["skipped_ticks"] == ticks and sent > ticks // 2
    assert report["packets_lost"] == 0 and report["packets_answered"] + report["packets_late"] == sent
    assert report["packets_answered"] >= sent // 2
    assert report["contacts"] > 0 and report["max_force_n"] > 1


def test_a_device_session_crosses_from_one_container_to_another(image, secrets):
    network = f"hapticd-test-{os.getpid()}"
    server = f"server-{os.getpid()}"
    podman("network", "create", network)
    try:
        podman("run", "-d", "--name", server, "--network", network, "--network-alias", "server",
               "-v", f"{secrets}:/secrets:ro", image, "--host", "0.0.0.0", "--tls-cert", "/secrets/cert.pem",
               "--tls-key", "/secrets/key.pem", "--access-token-file", "/secrets/token", "--log-level", "warning")
        deadline = time.monotonic() + 20
        while "\"udp\"" not in podman("logs", server).stdout:
            assert time.monotonic() < deadline, podman("logs", server).stderr
            time.sleep(0.1)
        run = podman("run", "--rm", "--network", network, "-v", f"{secrets}:/secrets:ro", "--entrypoint",
                     "hapticd-proxy", image, "--server", "server:7460", "--tls-ca", "/secrets/cert.pem",
                     "--access-token-file", "/secrets/token", "--seconds", "2", "--path", "press")
        assert_served(proxy_report(run.stdout), 2000)
    finally:
        podman("rm", "-f", server, check=False)
        podman("network", "rm", network, check=False)


def test_compose_runs_a_session_through_the_relay(image, secrets):
    project = f"hl{os.getpid()}"
    compose = ["podman-compose", "-p", project, "-f", str(REPO / "deploy" / "compose.yaml")]
    env = {**ENV, "HAPTICD_SECRETS": str(secrets), "HAPTICD_DELAY_MS": "10", "HAPTICD_LOSS": "0.01",
           "HAPTICD_SECONDS": "2"}
    up = subprocess.run([*compose, "up", "-d"], capture_output=True, text=True, timeout=120, env=env)
    try:
        assert up.returncode == 0, up.stderr
        device = f"{project}_device_1"
        podman("wait", device, timeout=60)
        report = proxy_report(podman("logs", device).stdout)
        subprocess.run([*compose, "stop"], capture_output=True, text=True, timeout=120, env=env)
        relay_logs = podman("logs", f"{project}_relay_1").stdout
        summary = json.loads([line for line in relay_logs.splitlines() if line.startswith("{\"up\"")][-1])
    finally:
        subprocess.run([*compose, "down"], capture_output=True, text=True, timeout=120, env=env)
        podman("network", "rm", f"{project}_lab", check=False)
    # 10 ms each way through the relay's container, between the other two
    assert 20_000 <= report["wire_rtt_p50_us"] <= 30_000
    assert summary["flows"] == 1 and summary["up"]["in"] == report["packets_sent"]
    assert report["packets_sent"] + report["skipped_ticks"] == 2000
    assert 0 < summary["up"]["lost"] + summary["down"]["lost"] < 120


def test_the_deployment_plays_as_a_pod_that_serves_a_device(image, secrets, tmp_path):
    k8s = REPO / "deploy" / "k8s"
    # podman 4.3 writes a Secret's data values to the volume as they are, without
    # decoding base64: its podman secret holds the files' text (a cluster takes base64)
    lines = ["apiVersion: v1", "kind: Secret", "metadata:", "  name: hapticd-secrets", "type: Opaque", "data:"]
    for name in ("cert.pem", "key.pem", "token"):
        lines.append(f"  {name}: |")
        lines += ["    " + line for line in (secrets / name).read_text().rstrip("\n").split("\n")]
    secret_file = tmp_path / "secret.yaml"
    secret_file.write_text("\n".join(lines) + "\n")
    podman("secret", "rm", "hapticd-secrets", check=False)
    podman("secret", "create", "hapticd-secrets", str(secret_file))
    pod = "hapticd-pod-0"
    try:
        podman("kube", "play", "--replace", "--configmap", str(k8s / "scene-configmap.yaml"),
               str(k8s / "deployment.yaml"))
        server = f"{pod}-server"
        deadline = time.monotonic() + 20
        while "serving" not in podman("logs", server).stderr:
            assert time.monotonic() < deadline, podman("logs", server).stderr
            time.sleep(0.1)
        # the ConfigMap's scene, two objects
        assert "(2 objects" in podman("logs", server).stderr
        limits = podman("inspect", server, "--format",
                        "{{.HostConfig.CpuQuota}} {{.HostConfig.CpuPeriod}} {{.HostConfig.Memory}} "
                        "{{.HostConfig.CapAdd}}")
        assert limits.stdout.split() == ["100000", "100000", str(256 << 20), "[CAP_SYS_NICE]"]
        run = podman("run", "--rm", "--pod", pod, "-v", f"{secrets}:/secrets:ro", "--entrypoint", "hapticd-proxy",
                     image, "--server", "127.0.0.1:7460", "--tls-ca", "/secrets/cert.pem", "--access-token-file",
                     "/secrets/token", "--seconds", "1", "--path", "press")
        assert_served(proxy_report(run.stdout), 1000)
    finally:
        podman("pod", "rm", "-f", pod, check=False)
        podman("volume", "rm", "-f", "hapticd-secrets", "hapticd-scene", check=False)
        podman("secret", "rm", "hapticd-secrets", check=False)
