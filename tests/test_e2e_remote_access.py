"""Off loopback the control channel needs TLS and the access token: the server refuses
to start without them, and an untrusted peer must Hello with the token before anything
else. The realtime channel needs neither: its datagrams carry the session key's tag.
The Python side runs with the blocking Client and with the AsyncClient (`connect`)."""

import json
import socket
import ssl
import subprocess

import hapticd
import pytest
from hapticd.v1 import hapticd_pb2 as pb
from server_process import running_server

TOKEN = "remote-token-0123456789"


def local_address() -> str:
    """This machine's address towards the outside (a UDP connect sends nothing)."""
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
        probe.connect(("192.0.2.1", 9))
        address = probe.getsockname()[0]
    assert not address.startswith("127."), "this machine has no address but loopback"
    return address


def make_certificate(tmp_path, address: str):
    cert, key = tmp_path / "cert.pem", tmp_path / "key.pem"
    subprocess.run(
        ["openssl", "req", "-x509", "-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:prime256v1",
         "-nodes", "-keyout", str(key), "-out", str(cert), "-days", "1",
         "-subj", f"/CN={address}", "-addext", f"subjectAltName=IP:{address}"],
        check=True, capture_output=True, timeout=30,
    )
    return cert, key


def test_leaving_loopback_without_tls_and_a_token_is_refused(bin_dir):
    done = subprocess.run(
        [str(bin_dir / "hapticd"), "--host", "0.0.0.0", "--tcp-port", "0", "--udp-port", "0"],
        capture_output=True, text=True, timeout=30,
    )
    assert done.returncode == 2
    assert done.stdout == ""
    assert "--host is 0.0.0.0, not loopback" in done.stderr and "--access-token-file" in done.stderr


def test_a_remote_peer_must_hello_with_the_token(bin_dir, tmp_path, connect):
    address = local_address()
    cert, key = make_certificate(tmp_path, address)
    token_file = tmp_path / "token"
    token_file.write_text(TOKEN + "\n")
    args = ["--host", address, "--tls-cert", str(cert), "--tls-key", str(key),
            "--access-token-file", str(token_file), "--log-level", "error"]
    with running_server(bin_dir, *args) as server:
        assert server.tcp.startswith(address + ":")
        tls = ssl.create_default_context(cafile=str(cert))

        # No TLS, or a CA that does not vouch for the server: refused before any Hello.
        with pytest.raises(hapticd.LocalError, match=f"address {server.tcp} is not loopback"):
            connect(server.tcp, access_token=TOKEN)
        (tmp_path / "other").mkdir()
        other_cert, _ = make_certificate(tmp_path / "other", address)
        untrusted = ssl.create_default_context(cafile=str(other_cert))
        with pytest.raises(hapticd.ConnectionClosed, match=f"TLS handshake with {server.tcp} failed"):
            connect(server.tcp, tls=untrusted, access_token=TOKEN)

        # No token, then a wrong one: refused by name, and nothing else is served.
        for token in ("", "not-the-token-at-all"):
            with pytest.raises(hapticd.RemoteError) as refused:
                connect(server.tcp, tls=tls, access_token=token)
            assert refused.value.code == "UNAUTHENTICATED"
            assert "access_token is not this server's token" in refused.value.message

        # The plain protocol without a Hello is refused too.
        raw = tls.wrap_socket(socket.create_connection(server.tcp.rsplit(":", 1)), server_hostname=address)
        request = pb.Request(request_id=3, get_scene=pb.GetScene()).SerializeToString()
        raw.sendall(len(request).to_bytes(4, "big") + request)
        length = int.from_bytes(raw.recv(4), "big")
        body = b""
        while len(body) < length:
            body += raw.recv(length - len(body))
        reply = pb.Reply.FromString(body)
        assert reply.request_id == 3
        assert reply.error.code == pb.Error.CODE_UNAUTHENTICATED
        raw.close()

        # With the token: scene, a session, and its datagrams over the machine's address.
        with connect(server.tcp, tls=tls, access_token=TOKEN) as client:
            assert client.scene().object("box").shape == "box" and client.role == "operator"
            nearest = client.closest_point_batch([[0.15, 0, 0.2], [0.15, 0, 0.12]])
            assert nearest.objects == ["box", "box"]
            assert nearest.signed_distance == pytest.approx([0.1, 0.02])
            info = client.open_session("impedance", start=(0.15, 0, 0.2))
            assert info.udp_host == address
            with hapticd.DeviceSession(info) as device:
                command = device.exchange((0.15, 0, 0.098), timeout_s=1.0)
            assert command.contact
            assert command.force[2] == pytest.approx(2000 * 0.002, rel=1e-3)
        assert server.alive


def test_the_cpp_proxy_reaches_a_remote_server_over_tls(bin_dir, tmp_path):
    address = local_address()
    cert, key = make_certificate(tmp_path, address)
    token_file = tmp_path / "token"
    token_file.write_text(TOKEN + "\n")
    wrong_token = tmp_path / "wrong"
    wrong_token.write_text("not-the-token-at-all\n")
    args = ["--host", address, "--tls-cert", str(cert), "--tls-key", str(key),
            "--access-token-file", str(token_file), "--log-level", "error"]
    with running_server(bin_dir, *args) as server:
        proxy = [str(bin_dir / "hapticd-proxy"), "--server", server.tcp, "--seconds", "0.5"]
        done = subprocess.run([*proxy, "--tls-ca", str(cert), "--access-token-file", str(token_file)],
                              capture_output=True, text=True, timeout=60)
        assert done.returncode == 0, done.stderr
        report = json.loads(done.stdout)
        # every tick of the 0.5 s run, sent or skipped after a stall of this shared machine
        assert report["packets_sent"] == report["ticks"] and report["ticks"] + report["skipped_ticks"] == 500
        assert report["ticks"] > 250 and report["packets_lost"] == 0
        # a wrong token, and no TLS at all, are refused by name
        done = subprocess.run([*proxy, "--tls-ca", str(cert), "--access-token-file", str(wrong_token)],
                              capture_output=True, text=True, timeout=60)
        assert done.returncode == 1 and "CODE_UNAUTHENTICATED" in done.stderr
        done = subprocess.run([*proxy, "--timeout-s", "2"], capture_output=True, text=True, timeout=60)
        assert done.returncode == 1
        # the CA must vouch for the server
        (tmp_path / "other").mkdir()
        other_cert, _ = make_certificate(tmp_path / "other", address)
        done = subprocess.run([*proxy, "--tls-ca", str(other_cert), "--access-token-file", str(token_file)],
                              capture_output=True, text=True, timeout=60)
        assert done.returncode == 1 and "TLS handshake" in done.stderr
        assert server.alive
