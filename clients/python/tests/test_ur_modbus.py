"""The UR bridge's Modbus side: register maps decode every type and word order exactly,
bad maps are refused by name, and ModbusForceSource and EnableInput read a real pymodbus
server over TCP (the default map is a Robotiq FT 300's layout); a Poller keeps the
newest reading and says when a device stopped answering."""

import asyncio
import json
import pathlib
import shutil
import socket
import struct
import subprocess
import threading
import time

import pytest
from pymodbus.server import ModbusSerialServer, ModbusTcpServer
from pymodbus.simulator import DataType, SimData, SimDevice

from hapticd.errors import HapticdError, LocalError
from hapticd.ur_modbus import (
    ROBOTIQ_FT300,
    Axis,
    EnableInput,
    ModbusForceSource,
    Poller,
    RegisterMap,
)


def words_of(fmt, value):
    raw = struct.pack(">" + fmt, value)
    return [int.from_bytes(raw[i : i + 2], "big") for i in range(0, len(raw), 2)]


@pytest.mark.parametrize(
    ("kind", "fmt", "value"),
    [("int16", "h", -1234), ("uint16", "H", 54321), ("int32", "i", -70000),
     ("uint32", "I", 3_000_000_000), ("float32", "f", -12.5)],
)  # fmt: skip
@pytest.mark.parametrize("word_order", ["big", "little"])
def test_every_type_decodes_in_either_word_order(kind, fmt, value, word_order):
    words = words_of(fmt, value)
    if word_order == "little":
        words = words[::-1]
    width = len(words)
    m = RegisterMap(
        axes=(Axis(10, kind, 2.0), Axis(10 + width, kind, 1.0), Axis(10 + 2 * width, kind, -1.0)),
        word_order=word_order,
    )
    assert m.span == (10, 3 * width)
    force = m.decode(words * 3)
    assert force.tolist() == pytest.approx([2 * value, value, -value])


def test_the_default_map_is_the_ft300s():
    assert ROBOTIQ_FT300.span == (180, 3)
    assert ROBOTIQ_FT300.device_id == 9
    assert ROBOTIQ_FT300.decode([1250, 65536 - 300, 0]).tolist() == pytest.approx([12.5, -3.0, 0.0])


@pytest.mark.parametrize(
    ("data", "named"),
    [({"axes": []}, "three axes"), ({"axes": [{"address": 0}] * 3}, "address, type and scale"),
     ({"axes": [{"address": 0, "type": "int8", "scale": 1}] * 3}, "type is 'int8'"),
     ({"axes": [{"address": 0, "type": "int16", "scale": 0}] * 3}, "scale is 0"),
     ({"axes": [{"address": 0, "type": "int16", "scale": 1}, {"address": 0, "type": "int16",
       "scale": 1}, {"address": 200, "type": "int16", "scale": 1}]}, "span 201 registers"),
     ({"axes": [{"address": 0, "type": "int16", "scale": 1}] * 3, "frame": "world"}, "frame"),
     ({"axis": []}, "unknown key")],
)  # fmt: skip
def test_bad_maps_are_refused_by_name(data, named):
    with pytest.raises(LocalError, match=named):
        RegisterMap.from_json(data, "test")


def test_a_map_file_is_read(tmp_path):
    path = tmp_path / "map.json"
    path.write_text(json.dumps({"device_id": 3, "axes": [{"address": a, "type": "int32",
                                "scale": 0.001} for a in (0, 2, 4)]}))  # fmt: skip
    m = RegisterMap.read(str(path))
    assert (m.device_id, m.span) == (3, (0, 6))
    with pytest.raises(LocalError, match="--modbus-map"):
        RegisterMap.read(str(tmp_path / "missing.json"))


class Server:
    """A real pymodbus TCP server on its own event loop thread, answering device
    device_id's register reads from the dict registers (change it to change them); with
    serial_port, a Modbus RTU server on that serial device instead."""

    def __init__(self, device_id, registers, serial_port=None):
        self.registers = registers

        async def fill(function_code, start_address, address, count, values, set_values):
            for a in range(address, address + count):
                values[a - start_address] = self.registers.get(a, 0)
            return None

        data = [SimData(0, count=512, values=0, datatype=DataType.REGISTERS)]
        device = SimDevice(device_id, simdata=data, action=fill)
        self.loop = asyncio.new_event_loop()
        self.server = None

        async def listen():
            if serial_port:
                self.server = ModbusSerialServer(device, port=serial_port, baudrate=19200)
                await self.server.serve_forever(background=True)
                return 0
            self.server = ModbusTcpServer(device, address=("127.0.0.1", 0))
            await self.server.serve_forever(background=True)
            return self.server.transport.sockets[0].getsockname()[1]

        self.thread = threading.Thread(target=self.loop.run_forever, daemon=True)
        self.thread.start()
        self.port = asyncio.run_coroutine_threadsafe(listen(), self.loop).result(5)

    def endpoint(self):
        return f"127.0.0.1:{self.port}"

    def close(self):
        asyncio.run_coroutine_threadsafe(self.server.shutdown(), self.loop).result(5)
        self.loop.call_soon_threadsafe(self.loop.stop)
        self.thread.join(5)


def connect_when_listening(make):
    for _ in range(50):
        try:
            return make()
        except HapticdError:
            threading.Event().wait(0.05)
    return make()


def test_the_force_source_reads_an_ft300_layout_over_tcp():
    # 15 N, -2.5 N, 0.2 N
    server = Server(9, {180: 1500, 181: 65536 - 250, 182: 20})
    try:
        source = connect_when_listening(lambda: ModbusForceSource(server.endpoint(), ROBOTIQ_FT300))
        try:
            assert source.read().tolist() == pytest.approx([15.0, -2.5, 0.2])
            server.registers[182] = 65536 - 1000
            assert source.read()[2] == pytest.approx(-10.0)
        finally:
            source.close()
    finally:
        server.close()


@pytest.fixture
def serial_line(tmp_path):
    """Two serial devices joined back to back (socat's pseudo-terminals): a Modbus RTU
    line without the hardware. Yields (server end, client end)."""
    assert shutil.which("socat"), "socat is installed by deploy/install.sh"
    ends = (str(tmp_path / "server-tty"), str(tmp_path / "client-tty"))
    line = subprocess.Popen(["socat", *(f"pty,raw,echo=0,link={end}" for end in ends)])
    try:
        deadline = time.monotonic() + 10
        while not all(pathlib.Path(end).exists() for end in ends):
            assert time.monotonic() < deadline and line.poll() is None, "socat did not start"
            time.sleep(0.02)
        yield ends
    finally:
        line.terminate()
        line.wait(5)


def test_the_force_source_reads_an_ft300_over_modbus_rtu(serial_line):
    server_end, client_end = serial_line
    server = Server(9, {180: 1500, 181: 65536 - 250, 182: 20}, serial_port=server_end)
    try:
        source = connect_when_listening(lambda: ModbusForceSource(client_end, ROBOTIQ_FT300))
        try:
            assert source.read().tolist() == pytest.approx([15.0, -2.5, 0.2])
            server.registers[182] = 65536 - 1000
            poller = Poller(source.read, 0.01, "the FT 300")
            try:
                deadline = time.monotonic() + 10
                while poller.latest(max_age_s=5.0)[2] != pytest.approx(-10.0):
                    assert time.monotonic() < deadline, "the poller never read the change"
                    time.sleep(0.01)
            finally:
                poller.close()
        finally:
            source.close()
    finally:
        server.close()


def test_the_enable_input_is_a_bit_of_register_0():
    server = Server(255, {0: 0b100})
    try:
        enable = connect_when_listening(lambda: EnableInput(server.endpoint(), 2))
        try:
            assert enable.held()
            server.registers[0] = 0b011
            assert not enable.held()
        finally:
            enable.close()
    finally:
        server.close()
    with pytest.raises(LocalError, match="--enable-input"):
        EnableInput("127.0.0.1:1", 16)


def test_no_device_is_a_named_error():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    with pytest.raises(HapticdError, match=f"127.0.0.1:{port}"):
        ModbusForceSource(f"127.0.0.1:{port}", ROBOTIQ_FT300, timeout_s=0.2)


class Device:
    """A device read by a Poller: counts its reads, fails while told to."""

    def __init__(self):
        self.reads = 0
        self.failing = False

    def read(self):
        if self.failing:
            raise HapticdError("the bus timed out")
        self.reads += 1
        return self.reads


def wait_until(condition, timeout_s=10.0):
    deadline = time.monotonic() + timeout_s
    while not condition():
        assert time.monotonic() < deadline, "timed out"
        time.sleep(0.005)


def test_a_poller_keeps_the_newest_reading_and_names_a_device_gone_quiet():
    device = Device()
    poller = Poller(device.read, 0.002, "the test device")
    try:
        assert device.reads >= 1  # the first reading was taken before it returned
        wait_until(lambda: device.reads >= 5)
        newest = poller.latest(max_age_s=1.0)
        assert newest >= 4 and newest <= device.reads
        device.failing = True
        # a reading stays good until it is older than the age asked for
        time.sleep(0.05)
        with pytest.raises(HapticdError, match=r"the test device .*the bus timed out"):
            poller.latest(max_age_s=0.02)
        device.failing = False
        wait_until(lambda: device.reads > newest + 2)
        assert poller.latest(max_age_s=1.0) > newest
    finally:
        poller.close()
    stopped_at = device.reads
    time.sleep(0.02)
    assert device.reads == stopped_at, "the thread went on after close()"


def test_a_device_that_cannot_be_read_at_first_is_refused_at_once():
    device = Device()
    device.failing = True
    with pytest.raises(HapticdError, match="the bus timed out"):
        Poller(device.read, 0.002, "the test device")
