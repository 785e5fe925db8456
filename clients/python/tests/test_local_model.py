"""The device side of a local-model session in Python: fragments put together exactly,
and the server's own renderer (loaded from build/lib) pressed into a model's box."""

import random

import numpy as np
import pytest

from hapticd.errors import LocalError, ProtocolError
from hapticd.local_model import CHUNK_BYTES, MAX_FRAGMENTS, LocalRenderer, ModelAssembler
from hapticd.v1 import hapticd_pb2 as pb

STIFFNESS = 5000.0
SKIN_N = 1e-2  # the god-object rests on the scene's tolerance above a face (1 um here)


def fragments(encoded: bytes, version: int) -> list[pb.ModelFragment]:
    count = max(1, -(-len(encoded) // CHUNK_BYTES))
    return [
        pb.ModelFragment(version=version, index=i, count=count,
                         data=encoded[i * CHUNK_BYTES:(i + 1) * CHUNK_BYTES])
        for i in range(count)
    ]


def box_model(version: int, top: float = 0.1, objects: int = 1) -> bytes:
    """A model holding a 5000 N/m box whose top face is z = top (and, for size, more
    boxes far below it)."""
    model = pb.LocalModel(version=version, time_s=0.0, radius=0.5, tolerance=1e-6)
    model.center.z = top
    for k in range(objects):
        box = model.objects.add(name=f"box{k}")
        extents = box.shape.box.half_extents
        extents.x = extents.y = extents.z = 0.05
        box.pose.position.z = top - 0.05 - 0.2 * k
        box.pose.orientation.w = 1
        box.material.stiffness = STIFFNESS
    return model.SerializeToString()


def open_request(**fields) -> bytes:
    request = pb.OpenSession(device_type=pb.DEVICE_TYPE_IMPEDANCE, degrees_of_freedom=3,
                             max_force=10, max_velocity=1, rate_hz=1000,
                             remote_mode=pb.REMOTE_MODE_LOCAL_MODEL, **fields)
    request.start.z = 0.12
    return request.SerializeToString()


def test_fragments_in_any_order_with_duplicates_make_the_model():
    encoded = box_model(3, objects=40)
    parts = fragments(encoded, 3)
    assert len(parts) > 2
    order = parts + parts[:2]
    random.Random(5).shuffle(order)
    assembler = ModelAssembler()
    done = [assembler.offer(p) for p in order]
    assert sum(d is not None for d in done) == 1
    assert next(d for d in done if d is not None) == encoded
    assert assembler.rejected == 0
    # the same version again, and an older one, are not offered twice
    assert all(assembler.offer(p) is None for p in parts + fragments(box_model(2), 2))


def test_a_newer_version_drops_the_older_half_gathered():
    old, new = box_model(1, objects=40), box_model(2, objects=3)
    assembler = ModelAssembler()
    assert assembler.offer(fragments(old, 1)[0]) is None
    assert [assembler.offer(p) for p in fragments(new, 2)][-1] == new
    # the rest of version 1 is too old now
    assert all(assembler.offer(p) is None for p in fragments(old, 1)[1:])


def test_fragments_outside_the_bounds_are_rejected():
    assembler = ModelAssembler()
    bad = [
        pb.ModelFragment(version=1, index=0, count=0, data=b"x"),
        pb.ModelFragment(version=1, index=2, count=2, data=b"x"),
        pb.ModelFragment(version=1, index=0, count=MAX_FRAGMENTS + 1, data=b"x"),
        pb.ModelFragment(version=1, index=0, count=1, data=b"x" * (CHUNK_BYTES + 1)),
        pb.ModelFragment(version=1, index=0, count=2, data=b"short"),  # not the last: a whole chunk
    ]
    assert all(assembler.offer(f) is None for f in bad)
    assert assembler.rejected == len(bad)


def test_the_renderer_presses_into_the_models_box():
    with LocalRenderer(open_request()) as renderer:
        assert renderer.model_version == 0
        # free space before any model
        assert np.allclose(renderer.tick((0, 0, 0.09), (0, 0, 0), (0, 0, 0), 0.001).force, 0)
    with LocalRenderer(open_request()) as renderer:
        assert renderer.accept(box_model(1), 0.0)
        assert renderer.model_version == 1 and renderer.covers((0, 0, 0.12))
        assert not renderer.accept(box_model(1), 0.0)  # not newer
        held = np.zeros(3)
        for z in np.linspace(0.12, 0.099, 50):
            out = renderer.tick((0, 0, z), (0, 0, 0), held, 0.001)
            held = out.force
            # the proxy never enters the box
            assert out.avatar[2] >= 0.1 - 1e-9
        assert out.contact
        assert out.force[2] == pytest.approx(STIFFNESS * 0.001, abs=SKIN_N)
        assert np.allclose(out.force[:2], 0, atol=1e-9)
        np.testing.assert_allclose(renderer.avatar, out.avatar)


def test_bad_models_and_sessions_are_refused_by_name():
    with LocalRenderer(open_request()) as renderer:
        assert renderer.accept(box_model(1), 0.0)
        with pytest.raises(ProtocolError, match="does not decode"):
            renderer.accept(b"\xff\xff\xff", 0.0)
        broken = pb.LocalModel(version=2, radius=0.1, tolerance=1e-6)
        broken.objects.add(name="nothing")  # no shape
        with pytest.raises(ProtocolError, match=r"objects\[0\]"):
            renderer.accept(broken.SerializeToString(), 0.0)
        assert renderer.model_version == 1 and renderer.models_rejected == 2
    def request(device_type, max_force):
        return pb.OpenSession(device_type=device_type, degrees_of_freedom=3, max_force=max_force,
                              max_velocity=1, rate_hz=1000).SerializeToString()

    with pytest.raises(LocalError, match="max_force"):
        LocalRenderer(request(pb.DEVICE_TYPE_IMPEDANCE, -1))
    with pytest.raises(LocalError, match="admittance"):
        LocalRenderer(request(pb.DEVICE_TYPE_ADMITTANCE, 1))
    with pytest.raises(LocalError, match="does not parse"):
        LocalRenderer(b"\xff\xff")
    closed = LocalRenderer(open_request())
    closed.close()
    with pytest.raises(LocalError, match="closed"):
        closed.tick((0, 0, 0), (0, 0, 0), (0, 0, 0), 0.001)
