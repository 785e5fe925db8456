"""The golden wire vectors (proto/golden/vectors.json), shared with the C++ server's
tests: each text-format message serializes to exactly its hex and the hex parses back
to it; each datagram is the hex plus its keyed BLAKE2b tag; and the client's own
encoders (mesh arrays from numpy, the session handshake) produce the same bytes."""

import json
import os
import pathlib

import numpy as np
import pytest
from google.protobuf import descriptor_pool, message_factory, text_format

from hapticd import Material, Mesh, ObjectSpec, Pose
from hapticd import _codec as codec
from hapticd._datagram import decode_datagram, encode_datagram
from hapticd.v1 import hapticd_pb2 as pb

REPO = pathlib.Path(__file__).resolve().parents[3]
VECTORS_PATH = pathlib.Path(
    os.environ.get("HAPTICD_GOLDEN", REPO / "proto" / "golden" / "vectors.json")
)


def load_vectors():
    if not VECTORS_PATH.is_file():
        return []
    return json.loads(VECTORS_PATH.read_text())["vectors"]


VECTORS = load_vectors()
DATAGRAMS = [v for v in VECTORS if "datagram_hex" in v]
BY_NAME = {v["name"]: v for v in VECTORS}


def message_class(full_name):
    pool = descriptor_pool.Default()
    return message_factory.GetMessageClass(pool.FindMessageTypeByName(full_name))


def from_text(vector):
    return text_format.Parse(vector["text"], message_class(vector["message"])())


def test_the_vectors_exist():
    assert VECTORS_PATH.is_file(), f"no golden vectors at {VECTORS_PATH}"
    assert VECTORS, "the golden file holds no vectors"


@pytest.mark.parametrize("vector", VECTORS, ids=lambda v: v["name"])
def test_text_serializes_to_the_hex(vector):
    assert from_text(vector).SerializeToString().hex() == vector["hex"]


@pytest.mark.parametrize("vector", VECTORS, ids=lambda v: v["name"])
def test_the_hex_parses_back_to_the_text(vector):
    parsed = message_class(vector["message"]).FromString(bytes.fromhex(vector["hex"]))
    assert parsed == from_text(vector)
    # nothing unknown was kept aside: re-encoding gives the same bytes
    assert parsed.SerializeToString().hex() == vector["hex"]


@pytest.mark.parametrize("vector", DATAGRAMS, ids=lambda v: v["name"])
def test_the_datagram_is_the_message_and_its_tag(vector):
    key = bytes.fromhex(vector["key_hex"])
    message = from_text(vector)
    assert encode_datagram(message, key).hex() == vector["datagram_hex"]
    decoded = decode_datagram(bytes.fromhex(vector["datagram_hex"]), key, type(message))
    assert decoded == message


def test_the_clients_mesh_encoder_matches_the_golden_add_mesh():
    vector = BY_NAME.get("add_mesh")
    if vector is None:
        pytest.skip("no add_mesh vector")
    vertices = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], dtype=np.float64)
    triangles = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
    half = 0.7071067811865476
    spec = ObjectSpec(
        "tetra",
        Mesh(vertices, triangles, "mesh"),
        pose=Pose.of((1, 0, 0), (half, 0, 0, half)),
        material=Material(2000, 0, 0.5, 0.3, force_shading=False),
    )
    request = pb.Request(request_id=8)
    request.add_object.object.CopyFrom(codec.object_message(spec))
    assert request.SerializeToString().hex() == vector["hex"]


def test_the_clients_handshake_matches_the_golden_open_session(fake_server):
    vector = BY_NAME.get("open_session")
    if vector is None:
        pytest.skip("no open_session vector")

    def opened(request):
        # closing the client closes the session it opened
        if request.HasField("close_session"):
            return [pb.Reply(request_id=request.request_id, done=pb.Done())]
        body = pb.SessionOpened(session_id=1, session_key=bytes(32), udp_endpoint="127.0.0.1:9")
        return [pb.Reply(request_id=request.request_id, session_opened=body)]

    client, server = fake_server(opened)
    client.open_session(
        "admittance",
        degrees_of_freedom=6,
        max_force=40,
        max_velocity=0.25,
        rate_hz=500,
        avatar="sphere",
        avatar_radius=0.005,
        method="finger_proxy",
        passivity=True,
        start=(0, 0, 0.3),
    )
    sent = server.requests[0].open_session
    assert sent == from_text(vector).open_session


def test_the_clients_handshake_matches_the_golden_open_session_channel(fake_server):
    vector = BY_NAME.get("open_session_channel")
    if vector is None:
        pytest.skip("no open_session_channel vector")

    def opened(request):
        if request.HasField("close_session"):
            return [pb.Reply(request_id=request.request_id, done=pb.Done())]
        body = pb.SessionOpened(session_id=1, session_key=bytes(32), udp_endpoint="127.0.0.1:9")
        return [pb.Reply(request_id=request.request_id, session_opened=body)]

    client, server = fake_server(opened)
    client.open_session(
        max_force=10,
        max_velocity=2,
        start=(0, 0, 0.12),
        tdpa=True,
        deadband=0.1,
        deadband_force_floor=0.05,
        deadband_position_floor=0.0002,
        deadband_velocity_floor=0.004,
        keepalive_s=0.02,
    )
    assert server.requests[0].open_session == from_text(vector).open_session


def test_the_channel_telemetry_reads_back():
    vector = BY_NAME["telemetry_channel"]
    reply = pb.Reply.FromString(bytes.fromhex(vector["hex"]))
    session = codec.telemetry_from(reply.telemetry).sessions[0]
    assert session.channel_energy == -0.01125
    assert (session.server_energy_in, session.server_energy_out) == (0.005, 0.0025)
    assert (session.device_energy_in, session.device_energy_out) == (0.0125, 0.00375)
    assert (session.drift, session.max_drift, session.tdpa_activations) == (0.0004, 0.0095, 812)
    assert (session.states_held, session.keepalives) == (918, 90)
    assert (session.commands_held, session.predicted_ticks) == (907, 36)
