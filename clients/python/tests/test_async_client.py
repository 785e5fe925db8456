"""What only the AsyncClient does, on its own event loop (asyncio.run), against the fake
server: tasks sharing one connection each get their own reply, also out of order; a
cancelled request's late reply is dropped and the connection goes on; telemetry as an
async iterator; a DeviceSession closed inside the loop closes its session, which
close() waits for; two tasks may not read one subscription."""

import asyncio
import socket

import numpy as np
import pytest
from conftest import FakeServer
from test_connection import done, telemetry

import hapticd
from hapticd._async_connection import AsyncConnection
from hapticd.async_client import AsyncClient
from hapticd.v1 import hapticd_pb2 as pb


async def make(handler):
    ours, theirs = socket.socketpair()
    server = FakeServer(theirs, handler)
    connection = await AsyncConnection.adopt(ours, "127.0.0.1")
    return AsyncClient(connection, 2.0, "fake", "127.0.0.1:1"), server


def echo_ray(request):
    origin = request.ray_cast.origin
    hit = pb.RayHit(hit=True, distance=origin.x, point=origin, normal=pb.Vec3(z=1), object="x")
    return pb.Reply(request_id=request.request_id, ray_hit=hit)


def test_tasks_sharing_a_connection_each_get_their_own_reply_out_of_order():
    held = []

    def handler(request):
        # answer in batches of ten, the last asked first
        held.append(request)
        if len(held) < 10:
            return []
        replies = [echo_ray(r) for r in reversed(held)]
        held.clear()
        return replies

    async def main():
        client, server = await make(handler)
        async with client:
            hits = await asyncio.gather(
                *(client.ray_cast((k, 0, 1), (0, 0, -1)) for k in range(50))
            )
        server.close()
        return [hit.distance for hit in hits]

    assert asyncio.run(main()) == list(range(50))


def test_a_cancelled_request_drops_its_late_reply_and_the_connection_goes_on():
    pending = []

    def handler(request):
        if request.HasField("get_scene"):
            pending.append(request)
            return []
        late = [pb.Reply(request_id=r.request_id, scene=pb.SceneDescription()) for r in pending]
        pending.clear()
        return [*late, done(request, version=5)]

    async def main():
        client, server = await make(handler)
        async with client:
            waiting = asyncio.create_task(client.scene())
            await asyncio.sleep(0.05)
            waiting.cancel()
            with pytest.raises(asyncio.CancelledError):
                await waiting
            # the cancelled request's reply comes with this one's, and is dropped
            assert await client.clear_scene() == 5
            assert await client.clear_scene() == 5
        server.close()

    asyncio.run(main())


def test_telemetry_is_an_async_iterator_and_one_task_reads_it():
    def handler(request):
        if request.HasField("subscribe"):
            return [telemetry(request.request_id, t) for t in (1, 2, 3)]
        return [done(request)]

    async def main():
        client, server = await make(handler)
        async with client:
            async with await client.subscribe(100) as samples:
                times = []
                async for sample in samples:
                    times.append(sample.server_time_ns)
                    if len(times) == 3:
                        break
                assert times == [1, 2, 3]
                first = asyncio.create_task(samples.next(timeout_s=1))
                await asyncio.sleep(0.05)
                with pytest.raises(hapticd.LocalError, match="another task is already awaiting"):
                    await samples.next(timeout_s=1)
                first.cancel()
        server.close()

    asyncio.run(main())


def test_a_device_session_closed_on_the_loop_closes_its_session():
    closed = []

    def handler(request):
        kind = request.WhichOneof("body")
        if kind == "open_session":
            opened = pb.SessionOpened(
                session_id=7, session_key=bytes(32), udp_endpoint="127.0.0.1:9", max_datagram=512
            )
            return [pb.Reply(request_id=request.request_id, session_opened=opened)]
        if kind == "close_session":
            closed.append(request.close_session.session_id)
        return [done(request)]

    async def main():
        client, server = await make(handler)
        info = await client.open_session("impedance", start=np.zeros(3))
        with hapticd.DeviceSession(info):
            pass
        # the CloseSession was started on the loop; close() waits for it, and has
        # nothing left to close
        await client.close()
        server.close()

    asyncio.run(main())
    assert closed == [7]
