"""A smoke use of the installed hapticd package, run by deploy/check_package.sh in a
clean virtual environment (no checkout on its path): it imports from the environment,
carries its generated protocol code, knows its version, round-trips an object and a
query through the codec, and runs a request through the protocol core."""

import pathlib
import sys

import hapticd
from hapticd import _calls as calls
from hapticd import _codec as codec
from hapticd._protocol import ControlProtocol, ReplyArrived
from hapticd.v1 import hapticd_pb2 as pb

expected_version = sys.argv[1]
environment = pathlib.Path(sys.prefix).resolve()
for module in (hapticd, pb):
    where = pathlib.Path(module.__file__).resolve()
    assert where.is_relative_to(environment), f"{module.__name__} comes from {where}, not {environment}"
assert hapticd.__version__ == expected_version, (hapticd.__version__, expected_version)

# an object through the codec and back
spec = hapticd.ObjectSpec(
    "ball", hapticd.Sphere(0.05), pose=hapticd.Pose.of((0.1, 0.2, 0.3), (0, 1, 0, 0)),
    material=hapticd.Material(1500, damping=2),
)
message = pb.Object.FromString(codec.object_message(spec).SerializeToString())
assert message.name == "ball" and message.shape.sphere.radius == 0.05
pose = codec.pose_from(message.pose)
assert pose.position.tolist() == [0.1, 0.2, 0.3] and pose.orientation.tolist() == [0, 1, 0, 0]
assert codec.material_from(message.material) == spec.material

# a batch query through the protocol core: request out, reply in, numpy arrays out
protocol = ControlProtocol()
call = calls.closest_point_batch([[0.0, 0.0, 0.5]], 1.0, None)
request = next(call)
request_id, frame = protocol.send_request(request.body_name, request.body)
reply = pb.Reply(
    request_id=request_id,
    closest_points=pb.ClosestPoints(
        found=[True], signed_distance=[0.5], points=[0, 0, 0], normals=[0, 0, 1], objects=[0],
        object_names=pb.ObjectNames(indices=[0], names=["floor"]),
    ),
)
payload = reply.SerializeToString()
assert protocol.receive_data(len(payload).to_bytes(4, "big") + payload) == [ReplyArrived(request_id)]
try:
    call.send(protocol.take_reply(request_id))
except StopIteration as done:
    nearest = done.value
assert nearest.objects == ["floor"] and nearest.signed_distance.tolist() == [0.5]
print(f"hapticd {hapticd.__version__} from {pathlib.Path(hapticd.__file__).parent}: smoke use passed")
