"""The control channel's protocol core without a socket: requests become frames with
rising ids, bytes split anywhere become filed replies and events, telemetry is queued
per subscription (bounded), late and foreign replies are dropped or refused, and a
failure is kept and said by every later use. Then the calls (_calls.py) driven by hand,
as both transports drive them."""

import struct

import numpy as np
import pytest

from hapticd import _calls as calls
from hapticd._framing import FrameDecoder, encode_frame
from hapticd._protocol import ControlProtocol, ReplyArrived, TelemetryArrived
from hapticd.errors import ConnectionClosed, LocalError, ProtocolError, RemoteError
from hapticd.scene_edits import SceneEdits
from hapticd.v1 import hapticd_pb2 as pb


def reply_bytes(*replies: pb.Reply) -> bytes:
    return b"".join(encode_frame(r.SerializeToString()) for r in replies)


def sent_request(frame: bytes) -> pb.Request:
    (payload,) = FrameDecoder().feed(frame)
    return pb.Request.FromString(payload)


def done(request_id, version=1):
    return pb.Reply(request_id=request_id, done=pb.Done(scene_version=version))


def sample(request_id, time_ns):
    return pb.Reply(request_id=request_id, telemetry=pb.Telemetry(server_time_ns=time_ns))


def test_requests_leave_as_frames_with_rising_ids():
    protocol = ControlProtocol()
    first_id, first = protocol.send_request("clear_scene", pb.ClearScene())
    second_id, second = protocol.send_request("get_scene", pb.GetScene())
    assert (first_id, second_id) == (1, 2)
    assert first[:4] == struct.pack(">I", len(first) - 4)
    assert sent_request(first).request_id == 1 and sent_request(first).HasField("clear_scene")
    assert sent_request(second).HasField("get_scene")


def test_replies_split_anywhere_are_filed_under_their_requests():
    protocol = ControlProtocol()
    a, _ = protocol.send_request("clear_scene", pb.ClearScene())
    b, _ = protocol.send_request("clear_scene", pb.ClearScene())
    stream = reply_bytes(done(b, 20), done(a, 10))
    events = []
    for i in range(len(stream)):
        events += protocol.receive_data(stream[i : i + 1])
    assert events == [ReplyArrived(b), ReplyArrived(a)]
    assert protocol.take_reply(a).done.scene_version == 10
    assert protocol.take_reply(b).done.scene_version == 20
    # given once
    assert protocol.take_reply(a) is None


def test_telemetry_is_queued_per_subscription_bounded_oldest_dropped():
    protocol = ControlProtocol(telemetry_queue_length=3)
    subscription, _ = protocol.send_request(
        "subscribe", pb.Subscribe(rate_hz=10), subscription=True
    )
    other, _ = protocol.send_request("clear_scene", pb.ClearScene())
    events = protocol.receive_data(reply_bytes(*(sample(subscription, t) for t in range(5))))
    assert events == [TelemetryArrived(subscription)] * 5
    # a done for a subscription id is not telemetry: ignored
    assert protocol.receive_data(reply_bytes(done(subscription), done(other))) == [
        ReplyArrived(other)
    ]
    times = []
    while (reply := protocol.next_telemetry(subscription)) is not None:
        times.append(reply.telemetry.server_time_ns)
    assert times == [2, 3, 4]
    # an ended subscription's late samples are dropped
    protocol.end_subscription(subscription)
    assert protocol.receive_data(reply_bytes(sample(subscription, 9))) == []
    assert protocol.next_telemetry(subscription) is None


def test_a_refused_subscription_gets_its_error_queued():
    protocol = ControlProtocol()
    subscription, _ = protocol.send_request("subscribe", pb.Subscribe(rate_hz=1), subscription=True)
    error = pb.Reply(request_id=subscription, error=pb.Error(code=pb.Error.CODE_BAD_REQUEST))
    assert protocol.receive_data(reply_bytes(error)) == [TelemetryArrived(subscription)]
    assert protocol.next_telemetry(subscription).HasField("error")


def test_an_abandoned_request_drops_its_late_reply_and_an_arrived_one_is_handed_over():
    protocol = ControlProtocol()
    late, _ = protocol.send_request("clear_scene", pb.ClearScene())
    assert protocol.abandon(late) is None
    assert protocol.receive_data(reply_bytes(done(late))) == []
    arrived, _ = protocol.send_request("clear_scene", pb.ClearScene())
    protocol.receive_data(reply_bytes(done(arrived, 4)))
    assert protocol.abandon(arrived).done.scene_version == 4


def test_an_error_with_id_zero_answers_the_latest_request():
    protocol = ControlProtocol()
    protocol.send_request("clear_scene", pb.ClearScene())
    latest, _ = protocol.send_request("clear_scene", pb.ClearScene())
    error = pb.Reply(request_id=0, error=pb.Error(code=pb.Error.CODE_BAD_REQUEST, message="x"))
    assert protocol.receive_data(reply_bytes(error)) == [ReplyArrived(latest)]


@pytest.mark.parametrize(
    ("stream", "message"),
    [
        (reply_bytes(done(7)), "request_id 7, which was never sent"),
        (encode_frame(b"\xff\xff\xff\xff"), "reply frame does not parse"),
        (struct.pack(">I", 64 * 1024 * 1024 + 1), "over the 67108864-byte limit"),
    ],
)
def test_garbage_fails_the_protocol_and_every_later_use_says_why(stream, message):
    protocol = ControlProtocol()
    protocol.send_request("clear_scene", pb.ClearScene())
    with pytest.raises(ProtocolError, match=message):
        protocol.receive_data(stream)
    assert protocol.closed and isinstance(protocol.failure, ProtocolError)
    with pytest.raises(ConnectionClosed, match=f"^the connection is closed: .*{message}"):
        protocol.send_request("clear_scene", pb.ClearScene())


def test_a_second_reply_to_one_request_is_a_protocol_error():
    protocol = ControlProtocol()
    request_id, _ = protocol.send_request("clear_scene", pb.ClearScene())
    protocol.receive_data(reply_bytes(done(request_id)))
    protocol.take_reply(request_id)
    with pytest.raises(ProtocolError, match=f"replied to request_id {request_id} again"):
        protocol.receive_data(reply_bytes(done(request_id)))


def test_the_first_failure_is_kept_and_close_is_the_owners_doing():
    protocol = ControlProtocol()
    protocol.fail(ConnectionClosed("the server closed the connection (first)"))
    protocol.fail(ConnectionClosed("second"))
    with pytest.raises(
        ConnectionClosed, match=r"closed: the server closed the connection \(first\)$"
    ):
        protocol.check_open()
    owner = ControlProtocol()
    owner.close()
    owner.fail(ConnectionClosed("after close"))
    assert owner.failure is None
    with pytest.raises(LocalError, match=r"close\(\) was called"):
        owner.send_request("clear_scene", pb.ClearScene())


def test_a_request_over_the_frame_limit_is_refused_before_it_takes_an_id():
    protocol = ControlProtocol(max_frame_bytes=64)
    with pytest.raises(LocalError, match="a control frame holds at most 64"):
        protocol.send_request("remove_object", pb.RemoveObject(name="x" * 100))
    request_id, _ = protocol.send_request("clear_scene", pb.ClearScene())
    assert request_id == 1


# ---- calls, driven by hand ----


def drive(call, answer):
    """Runs call with answer(request) giving each reply: calls.run, no transport."""
    asked = []

    def perform(request):
        asked.append(request)
        return answer(request)

    return calls.run(call, perform), asked


def test_a_batch_of_closest_points_is_one_packed_request_and_numpy_out():
    points = np.array([[0, 0, 0.5], [1, 2, 3.0]])

    def answer(request):
        sent = request.body
        assert list(sent.points) == points.ravel().tolist() and sent.max_distance == 2
        result = pb.ClosestPoints(
            scene_version=3,
            found=[True, False],
            signed_distance=[0.25, float("inf")],
            points=[0, 0, 0.25, 0, 0, 0],
            normals=[0, 0, 1, 0, 0, 0],
            objects=[4, -1],
            object_names=pb.ObjectNames(indices=[4], names=["floor"]),
        )
        return pb.Reply(closest_points=result)

    nearest, asked = drive(calls.closest_point_batch(points, 2, None), answer)
    assert [r.body_name for r in asked] == ["closest_point_batch"]
    assert nearest.found.tolist() == [True, False]
    assert nearest.signed_distance[0] == 0.25 and np.isinf(nearest.signed_distance[1])
    assert nearest.point.shape == (2, 3) and nearest.normal[0].tolist() == [0, 0, 1]
    assert nearest.object_index.tolist() == [4, -1] and nearest.objects == ["floor", ""]
    assert nearest.scene_version == 3 and len(nearest) == 2


def test_a_batch_of_contacts_is_laid_end_to_end_with_offsets():
    def answer(request):
        assert list(request.body.radii) == [0.1]
        result = pb.ContactsBatch(
            counts=[2, 0, 1],
            objects=[0, 1, 1],
            points=[0, 0, 0, 1, 1, 1, 2, 2, 2],
            normals=[0, 0, 1] * 3,
            depths=[0.1, 0.2, 0.3],
            object_names=pb.ObjectNames(indices=[0, 1], names=["box", "ball"]),
        )
        return pb.Reply(contacts_batch=result)

    found, _ = drive(calls.find_contacts_batch(np.zeros((3, 3)), 0.1, None), answer)
    assert found.counts.tolist() == [2, 0, 1] and found.offsets.tolist() == [0, 2, 2, 3]
    assert found.center_index.tolist() == [0, 0, 2]
    assert found.objects == ["box", "ball", "ball"]
    assert [c.object for c in found.contacts_of(0)] == ["box", "ball"]
    assert found.contacts_of(1) == [] and found.contacts_of(-1)[0].depth == 0.3
    with pytest.raises(IndexError, match="center 3 is outside this batch of 3"):
        found.contacts_of(3)


def test_counts_that_do_not_add_up_are_the_servers_fault():
    broken = pb.ContactsBatch(counts=[2], objects=[0], depths=[0.1], points=[0, 0, 0])

    with pytest.raises(ProtocolError, match="invalid ContactsBatch: it holds 1 object values"):
        drive(
            calls.find_contacts_batch(np.zeros((1, 3)), 0, None),
            lambda r: pb.Reply(contacts_batch=broken),
        )


def test_one_origin_goes_on_the_wire_once_and_one_direction_is_repeated():
    def answer(request):
        n = len(request.body.directions) // 3
        return pb.Reply(
            ray_hits=pb.RayHits(
                hit=[False] * n,
                distance=[0] * n,
                points=[0] * 3 * n,
                normals=[0] * 3 * n,
                objects=[""] * n,
            )
        )

    fan = np.array([[1.0, 0, 0], [0, 1, 0], [0, 0, 1], [0, 0, -1]])
    hits, asked = drive(calls.ray_cast_batch((0, 0, 1), fan, 2, None), answer)
    assert list(asked[0].body.origins) == [0, 0, 1]
    assert list(asked[0].body.directions) == fan.ravel().tolist()
    assert len(hits.hit) == 4
    starts = np.array([[0, 0, 1.0], [1, 0, 1]])
    _, asked = drive(calls.ray_cast_batch(starts, (0, 0, -1), 2, None), answer)
    assert list(asked[0].body.origins) == starts.ravel().tolist()
    assert list(asked[0].body.directions) == [0, 0, -1, 0, 0, -1]


@pytest.mark.parametrize(
    ("call", "message"),
    [
        (
            lambda: calls.closest_point_batch(np.zeros((2, 2)), 1, None),
            r"points has shape \(2, 2\)",
        ),
        (
            lambda: calls.closest_point_batch([[0, 0, float("nan")]], 1, None),
            r"points\[0\] is \[0.0, 0.0, nan\]; it must be finite",
        ),
        (
            lambda: calls.closest_point_batch(np.zeros((1_000_001, 3)), 1, None),
            r"points has 1000001 rows; at most 1000000 are served in one request",
        ),
        (lambda: calls.closest_point_batch(np.zeros((1, 3)), 0, None), "max_distance is 0.0"),
        (
            lambda: calls.find_contacts_batch(np.zeros((2, 3)), [0.1, -1], None),
            r"radius\[1\] is -1.0; it must be a finite number >= 0",
        ),
        (
            lambda: calls.find_contacts_batch(np.zeros((2, 3)), [0.1, 0.2, 0.3], None),
            r"radius has shape \(3,\); it must be \(2,\)",
        ),
        (
            lambda: calls.ray_cast_batch(np.zeros((2, 3)), np.ones((3, 3)), 1, None),
            r"directions has 3 rows and origins 2; one direction per origin",
        ),
        (
            lambda: calls.ray_cast_batch((0, 0, 0), [[1, 0, 0], [0, 0, 0]], 1, None),
            r"directions\[1\] is zero",
        ),
        (
            lambda: calls.ray_cast_batch((0, 0, 0), np.ones((1_000_001, 3)), 1, None),
            r"directions has 1000001 rows; at most 1000000",
        ),
    ],
)
def test_bad_batches_are_refused_before_anything_is_asked(call, message):
    with pytest.raises(LocalError, match=message):
        next(call())


def test_an_error_thrown_into_a_call_can_be_handled_there():
    book = calls.SessionBook()
    book.opened(5)

    def not_found(request):
        raise RemoteError("NOT_FOUND", pb.Error.CODE_NOT_FOUND, "no session 5", "close_session")

    # closing one the server has reclaimed: quiet, and forgotten
    result, asked = drive(calls.close_own_session(book, 5), not_found)
    assert result is None and [r.body_name for r in asked] == ["close_session"]
    assert not book.is_open(5)


def test_a_partial_material_is_one_request_naming_only_its_fields():
    edits = SceneEdits()
    edits.set_material("box", {"damping": 3.0})
    message = edits.message().edits[0].set_material
    version, asked = drive(
        calls.edit("set_material", message, 2.0),
        lambda r: pb.Reply(done=pb.Done(scene_version=9)),
    )
    assert version == 9 and [r.body_name for r in asked] == ["set_material"]
    assert asked[0].body.WhichOneof("what") == "change" and asked[0].timeout_s == 2.0
    change = asked[0].body.change
    assert change.HasField("damping") and change.damping == 3.0
    for other in ("stiffness", "static_friction", "dynamic_friction", "force_shading"):
        assert not change.HasField(other), other
