"""The impairment relay (build/bin/hapticd-netem) on real datagrams over loopback: a
device socket sends through it to a server socket, both in this process, so one-way
delays are read on one clock: the send time in the datagram and the arrival time at the
other end, both CLOCK_MONOTONIC (a wall clock stepped by time sync would fake early
arrivals); a thread sends while the test receives. Each impairment is measured against what was asked (the
counts within 5 binomial standard deviations, delays within the jitter's bounds plus a
scheduling slack), the relay's own summary is checked against what arrived, garbage and
floods leave it running with its queues capped, and the same seed gives the same fates."""

import itertools
import json
import os
import random
import select
import signal
import socket
import struct
import subprocess
import threading
import time
from contextlib import contextmanager

import pytest

# what a loaded 2-core machine may add to a release, beyond the delay asked for, for
# all but the worst 1% of datagrams (the relay's own error is measured in bench/, not
# asserted here); the worst one may meet a stall of the relay or of the sending thread
# between stamping and sending (CI: 17 ms)
SLACK_S = 0.015
STALL_S = 0.100
HEADER = struct.Struct("!Iq")  # sequence number, send time (ns, CLOCK_REALTIME)
# Arrivals are stamped by the kernel as each datagram reaches the socket (SO_TIMESTAMPNS,
# CLOCK_REALTIME), so a stall of this test process while datagrams wait to be read does
# not add to their delays.
TIMESPEC = struct.Struct("@qq")
# Python's socket module does not name it; 35 on x86-64 and arm64 (asm-generic/socket.h)
SO_TIMESTAMPNS = getattr(socket, "SO_TIMESTAMPNS", 35)


@contextmanager
def running_relay(bin_dir, forward: str, *args: str):
    """hapticd-netem listening on an ephemeral port; yields (listen address, result),
    where result["summary"] holds the exit summary once the block ends."""
    process = subprocess.Popen(
        [str(bin_dir / "hapticd-netem"), "--listen", "127.0.0.1:0", "--forward", forward,
         "--realtime-priority", "0", *args],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    result = {}
    try:
        start = json.loads(process.stdout.readline())
        host, port = start["listen"].rsplit(":", 1)
        yield (host, int(port)), result
    finally:
        process.send_signal(signal.SIGTERM)
        out, err = process.communicate(timeout=10)
        assert process.returncode == 0, err
        result["summary"] = json.loads(out.strip().splitlines()[-1])


def udp_socket(bind=("127.0.0.1", 0)) -> socket.socket:
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    s.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 8 << 20)
    s.setsockopt(socket.SOL_SOCKET, SO_TIMESTAMPNS, 1)
    s.bind(bind)
    return s


def endpoint(s: socket.socket) -> str:
    host, port = s.getsockname()
    return f"{host}:{port}"


def send_stream(device, relay, count: int, spacing_s: float, size: int = 64) -> threading.Thread:
    """Starts sending count datagrams, each its sequence number and send time, paced
    spacing_s apart, from a thread (it sleeps between them, so the receiving test runs)."""

    def send() -> None:
        start = time.monotonic()
        for seq in range(count):
            wait = start + seq * spacing_s - time.monotonic()
            if wait > 0:
                time.sleep(wait)
            device.sendto(HEADER.pack(seq, time.time_ns()).ljust(size, b"\0"), relay)

    thread = threading.Thread(target=send, daemon=True)
    thread.start()
    return thread


def arrivals(s: socket.socket, quiet_s: float, sending: threading.Thread | None = None):
    """(data, arrival time ns as the kernel stamped it, source) of every datagram, until
    sending has ended and quiet_s passed with nothing."""
    got = []
    while True:
        if select.select([s], [], [], quiet_s)[0]:
            data, ancillary, _, source = s.recvmsg(65536, socket.CMSG_SPACE(TIMESPEC.size))
            stamps = [d for level, kind, d in ancillary
                      if (level, kind) == (socket.SOL_SOCKET, SO_TIMESTAMPNS)]
            assert stamps, "the kernel stamped no arrival"
            seconds, nanoseconds = TIMESPEC.unpack(stamps[0][:TIMESPEC.size])
            got.append((data, seconds * 1_000_000_000 + nanoseconds, source))
        elif sending is None or not sending.is_alive():
            return got


def receive(s: socket.socket, quiet_s: float, sending: threading.Thread | None = None):
    """(sequence, one-way delay s, source) of every datagram (as arrivals)."""
    got = []
    for data, arrived, source in arrivals(s, quiet_s, sending):
        seq, sent = HEADER.unpack_from(data)
        got.append((seq, (arrived - sent) / 1e9, source))
    return got


def assert_delays_within(delays: list[float], low: float, high: float) -> None:
    """Never earlier than low; all but the worst 1% by high + SLACK_S, all by high + STALL_S."""
    delays = sorted(delays)
    assert delays[0] >= low
    assert delays[-1 - len(delays) // 100] <= high + SLACK_S
    assert delays[-1] <= high + STALL_S


def binomial_slack(p: float, n: int) -> float:
    return 5 * (p * (1 - p) * n) ** 0.5 + 1


@pytest.fixture
def server():
    s = udp_socket()
    yield s
    s.close()


@pytest.fixture
def device():
    s = udp_socket()
    yield s
    s.close()


@pytest.mark.parametrize("spin", [[], ["--spin-us", "100"]], ids=["timer", "spin"])
def test_each_direction_gets_its_own_delay_and_jitter_within_bounds(bin_dir, server, device, spin):
    with running_relay(bin_dir, endpoint(server), "--up-delay-ms", "10", "--down-delay-ms", "30",
                       "--down-jitter-ms", "5", *spin) as (relay, result):
        sending = send_stream(device, relay, 400, 0.002)
        up = receive(server, 0.3, sending)
        assert sorted(seq for seq, _, _ in up) == list(range(400))
        delays = sorted(d for _, d, _ in up)
        assert_delays_within(delays, 0.010, 0.010)
        assert 0.010 <= delays[200] <= 0.012
        # the server answers each to where it came from: the flow's socket
        flow = up[0][2]
        assert all(source == flow for _, _, source in up)
        sending = send_stream(server, flow, 400, 0.002)
        down = receive(device, 0.3, sending)
    assert sorted(seq for seq, _, _ in down) == list(range(400))
    assert all(source == relay for _, _, source in down)
    delays = sorted(d for _, d, _ in down)
    assert_delays_within(delays, 0.025, 0.035)
    mean = sum(delays) / len(delays)
    assert 0.029 <= mean <= 0.032
    summary = result["summary"]
    for direction in ("up", "down"):
        assert summary[direction]["in"] == summary[direction]["out"] == 400
        assert summary[direction]["lost"] == summary[direction]["overflow"] == 0
    assert 29.5 <= summary["down"]["delay_ms"]["p50"] <= 30.5
    assert summary["down"]["delay_ms"]["max"] <= 35.0
    assert summary["flows"] == 1


def test_several_devices_at_once_each_get_a_flow_of_their_own_both_ways(bin_dir, server):
    devices = [udp_socket() for _ in range(3)]
    try:
        with running_relay(bin_dir, endpoint(server), "--delay-ms", "5") as (relay, result):
            # each device sends its own run of sequence numbers, interleaved with the others'
            sending = [send_stream(d, relay, 100, 0.002) for d in devices]
            for thread in sending:
                thread.join()
            up = receive(server, 0.3)
            flows = sorted({source for _, _, source in up})
            assert len(up) == 300 and len(flows) == 3, "one flow, one socket, per device"
            # the server answers each flow with that flow's own numbers (offset by a
            # thousand per flow): every device must get back its own and no other's
            for k, flow in enumerate(flows):
                for seq in range(50):
                    server.sendto(HEADER.pack(1000 * (k + 1) + seq, time.time_ns()), flow)
            answers = [receive(d, 0.3) for d in devices]
        owners = [{seq // 1000 for seq, _, _ in got} for got in answers]
        assert all(len(got) == 50 for got in answers)
        assert sorted(len(o) for o in owners) == [1, 1, 1] and len(set.union(*owners)) == 3
        assert all(source == relay for got in answers for _, _, source in got)
        summary = result["summary"]
        assert summary["flows"] == 3
        assert (summary["up"]["in"], summary["up"]["out"]) == (300, 300)
        assert (summary["down"]["in"], summary["down"]["out"]) == (150, 150)
    finally:
        for d in devices:
            d.close()


def test_independent_loss_has_its_rate_and_the_summary_counts_it(bin_dir, server, device):
    with running_relay(bin_dir, endpoint(server), "--loss", "20%", "--seed", "3") as (relay, result):
        sending = send_stream(device, relay, 3000, 0.0002)
        got = receive(server, 0.3, sending)
    assert abs((3000 - len(got)) - 600) <= binomial_slack(0.2, 3000)
    summary = result["summary"]["up"]
    assert summary["in"] == 3000
    assert summary["lost"] == 3000 - len(got)
    assert summary["out"] == len(got)


def test_a_stopped_relay_counts_what_had_arrived_and_what_it_held(bin_dir, server, device):
    process = subprocess.Popen(
        [str(bin_dir / "hapticd-netem"), "--listen", "127.0.0.1:0", "--forward", endpoint(server),
         "--delay-ms", "60000", "--realtime-priority", "0"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    host, port = json.loads(process.stdout.readline())["listen"].rsplit(":", 1)
    for seq in range(20):  # taken in and held for a minute
        device.sendto(HEADER.pack(seq, 0), (host, int(port)))
    time.sleep(0.2)
    # paused, it cannot read the next ones before the stop comes: it wakes with both
    # the stop and 30 datagrams waiting
    process.send_signal(signal.SIGSTOP)
    for seq in range(20, 50):
        device.sendto(HEADER.pack(seq, 0), (host, int(port)))
    process.send_signal(signal.SIGTERM)
    process.send_signal(signal.SIGCONT)
    out, err = process.communicate(timeout=10)
    assert process.returncode == 0, err
    up = json.loads(out.strip().splitlines()[-1])["up"]
    assert (up["in"], up["held"], up["out"], up["unsent"]) == (50, 50, 0, 0)


def missing_runs(received: set[int], count: int) -> list[int]:
    runs, run = [], 0
    for seq in range(count):
        if seq in received:
            if run:
                runs.append(run)
            run = 0
        else:
            run += 1
    return runs + ([run] if run else [])


def test_gilbert_elliott_loss_comes_in_bursts_of_the_asked_length(bin_dir, server, device):
    # p 0.05, r 0.2: a fifth of the datagrams lost, in bursts of 5 on average
    with running_relay(bin_dir, endpoint(server), "--up-loss-burst", "0.05,0.2", "--seed", "4") as (relay, _):
        sending = send_stream(device, relay, 5000, 0.0002)
        got = {seq for seq, _, _ in receive(server, 0.3, sending)}
    runs = missing_runs(got, 5000)
    lost = sum(runs)
    assert abs(lost / 5000 - 0.2) < 0.05
    assert 3.5 <= lost / len(runs) <= 6.5
    # the same rate lost independently would average bursts of 1.25
    assert len(runs) < 0.5 * lost


def test_reordering_and_duplication_have_their_shares(bin_dir, server, device):
    with running_relay(bin_dir, endpoint(server), "--delay-ms", "20", "--reorder", "0.3",
                       "--duplicate", "0.1", "--seed", "5") as (relay, result):
        sending = send_stream(device, relay, 2000, 0.001)
        got = receive(server, 0.3, sending)
    seqs = [seq for seq, _, _ in got]
    assert set(seqs) == set(range(2000))
    duplicates = len(seqs) - 2000
    assert abs(duplicates - 200) <= binomial_slack(0.1, 2000)
    at_once = sum(1 for _, d, _ in got if d < 0.010)
    # a duplicated datagram's two copies share its fate
    assert abs(at_once - 0.3 * len(seqs)) <= binomial_slack(0.3, len(seqs)) + 10
    # the ones sent at once overtake the ones held back: most arrive before some earlier
    # datagram that was held (fewer where the sending thread stalled past the delay)
    held_after = [False] * len(got)
    lowest_held = float("inf")
    for i in range(len(got) - 1, -1, -1):
        held_after[i] = lowest_held < got[i][0]
        if got[i][1] >= 0.010:
            lowest_held = min(lowest_held, got[i][0])
    overtakers = sum(1 for i, (_, d, _) in enumerate(got) if d < 0.010 and held_after[i])
    assert overtakers >= at_once // 2
    summary = result["summary"]["up"]
    assert summary["duplicated"] == duplicates
    assert summary["out"] == len(seqs)


def test_the_same_seed_gives_the_same_fates(bin_dir, server, device):
    def fates(seed: str) -> set[int]:
        with running_relay(bin_dir, endpoint(server), "--loss", "0.3", "--duplicate", "0.2",
                           "--seed", seed) as (relay, _):
            sending = send_stream(device, relay, 1000, 0.0002)
            return {seq for seq, _, _ in receive(server, 0.3, sending)}
    first, again, other = fates("9"), fates("9"), fates("10")
    assert first == again
    assert len(first ^ other) > 200


def test_a_delay_trace_is_replayed(bin_dir, server, device, tmp_path):
    trace = tmp_path / "trace.csv"
    trace.write_text("one_way_ms\n5\n40\n20\n")
    with running_relay(bin_dir, endpoint(server), "--up-delay-trace", str(trace)) as (relay, _):
        sending = send_stream(device, relay, 30, 0.05)
        got = sorted(receive(server, 0.3, sending))
    assert len(got) == 30
    late = []
    for seq, delay, _ in got:
        want = (0.005, 0.040, 0.020)[seq % 3]
        assert want <= delay <= want + STALL_S, (seq, delay)
        if delay > want + SLACK_S:
            late.append((seq, delay))
    assert len(late) <= 1, late


def test_a_rate_cap_spaces_the_datagrams(bin_dir, server, device):
    # 1000 bytes at 800 kbit/s: 10 ms apart, whatever the sender's pace
    with running_relay(bin_dir, endpoint(server), "--up-rate-kbit", "800") as (relay, _):
        sending = send_stream(device, relay, 50, 0.0005, size=1000)
        times = [arrived / 1e9 for _, arrived, _ in arrivals(server, 0.3, sending)]
    assert len(times) == 50
    gaps = sorted(b - a for a, b in itertools.pairwise(times))
    assert 0.0095 <= gaps[len(gaps) // 2] <= 0.0105  # one late wake-up shortens the gap after it
    assert 0.49 - SLACK_S <= times[-1] - times[0] <= 0.49 + STALL_S


def test_garbage_floods_and_strangers_leave_it_relaying_with_its_queues_capped(bin_dir, server, device):
    generator = random.Random(6)
    # held 2 s: the flood is all in before the first of it is released, also on a loaded
    # machine (with 300 ms, CI once sent 2,001: the queue had drained meanwhile)
    with running_relay(bin_dir, endpoint(server), "--delay-ms", "2000", "--queue-limit", "1000",
                       "--max-flows", "4") as (relay, result):
        # a flood of garbage of every size, empty datagrams included, from one device
        flood_started = time.monotonic()
        for _ in range(5000):
            size = generator.choice([0, 1, 7, 100, 1500, 9000, 65507])
            device.sendto(os.urandom(size), relay)
        flood_s = time.monotonic() - flood_started
        # strangers beyond --max-flows
        strangers = [udp_socket() for _ in range(8)]
        for s in strangers:
            s.sendto(b"hello", relay)
        time.sleep(0.4)
        for s in strangers:
            s.close()
        while select.select([server], [], [], 2.5)[0]:
            server.recvfrom(65536)
        # still relaying
        device.sendto(HEADER.pack(1, time.time_ns()), relay)
        got = receive(server, 2.5)
        assert [seq for seq, _, _ in got] == [1]
    assert flood_s < 1.5, f"the flood took {flood_s:.1f} s: the bound below needs it held whole"
    up = result["summary"]["up"]
    # what reached the relay (a loaded machine's kernel drops some of the flood first) is
    # all accounted for, and beyond the queue's 1000 it was dropped, not queued
    assert up["in"] == up["out"] + up["overflow"] + up["unsent"] + up["held"]
    assert up["in"] > 1100 and up["overflow"] > 0
    summary = result["summary"]
    assert summary["up"]["out"] <= 1000 + 4 + 1
    assert summary["refused"] >= 4
    assert summary["flows"] <= 4


def test_bad_flags_are_refused_naming_the_flag(bin_dir):
    for args, message in [(["--delay-ms", "-5"], "--delay-ms is \"-5\""),
                          (["--down-loss", "2"], "--down-loss is \"2\""),
                          (["--colour", "red"], "unknown option \"--colour\"")]:
        run = subprocess.run([str(bin_dir / "hapticd-netem"), "--listen", "127.0.0.1:0", "--forward",
                              "127.0.0.1:9", *args], capture_output=True, text=True, timeout=10)
        assert run.returncode == 2
        assert message in run.stderr
    # a port already taken
    with udp_socket() as taken:
        address = endpoint(taken)
        run = subprocess.run([str(bin_dir / "hapticd-netem"), "--listen", address, "--forward", "127.0.0.1:9",
                              "--realtime-priority", "0"], capture_output=True, text=True, timeout=10)
    assert run.returncode == 1
    assert f"--listen {address}: cannot bind" in run.stderr


def test_a_device_session_through_the_relay_has_the_delay_asked_for(bin_dir):
    from server_process import running_server

    with running_server(bin_dir, "--log-level", "warning") as hapticd:
        with running_relay(bin_dir, hapticd.udp, "--delay-ms", "20", "--loss", "0.02",
                           "--seed", "8") as (relay, result):
            run = subprocess.run([str(bin_dir / "hapticd-proxy"), "--server", hapticd.tcp, "--udp-via",
                                  f"{relay[0]}:{relay[1]}", "--seconds", "2", "--path", "press",
                                  "--realtime-priority", "0"], capture_output=True, text=True, timeout=30)
            assert run.returncode == 0, run.stderr
            report = json.loads(run.stdout)
            time.sleep(0.1)
    # 20 ms each way, plus the loopback floor and the relay's own error
    assert 40_000 <= report["wire_rtt_p50_us"] <= 40_000 + SLACK_S * 1e6
    summary = result["summary"]
    assert summary["flows"] == 1
    assert summary["up"]["in"] == report["packets_sent"]
    # what the relay sent the device, but for the 40 ms in flight when the proxy stopped
    answered = report["packets_answered"] + report["packets_late"]
    assert answered <= summary["down"]["out"] <= answered + 45
    assert abs(summary["up"]["lost"] + summary["down"]["lost"] - 0.04 * 2000) <= binomial_slack(0.04, 2000) + 25
    # a command 40 ms old comes after its tick's wait: late (the proxy renders the newest one)
    assert report["packets_late"] > 0.9 * answered
