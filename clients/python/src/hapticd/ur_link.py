"""Whether the robot has closed the bridge's RTDE connections, as the kernel sees it.

ur_rtde notices a closed connection in its receive threads, up to a poll interval
later, and its control interface then reconnects on its own while the bridge may be
calling it (see ur_bridge._abandoned_robot_links). RtdeLinkWatch holds a duplicate of
each socket the process has open to the robot's RTDE port and asks the kernel, before
every call, whether the robot has shut it (FIN: POLLRDHUP) or reset it (POLLHUP,
POLLERR). The duplicate keeps the socket itself open after ur_rtde closes its own
descriptor, so the answer cannot flip back when ur_rtde reconnects on a new socket.
Linux only (/proc/self), like the realtime priority the bridge runs with.
"""

from __future__ import annotations

import ipaddress
import os
import select
import socket

RTDE_PORT = 30004
_GONE = select.POLLRDHUP | select.POLLHUP | select.POLLERR


def _robot_sockets(robot: str, port: int) -> set[int]:
    """The inodes of this process's TCP sockets connected to robot:port."""
    addresses = {ipaddress.ip_address(info[4][0]) for info in socket.getaddrinfo(robot, port)}
    inodes: set[int] = set()
    for table, width in (("/proc/self/net/tcp", 4), ("/proc/self/net/tcp6", 16)):
        try:
            with open(table, encoding="ascii") as lines:
                rows = lines.readlines()[1:]
        except FileNotFoundError:
            continue
        for row in rows:
            fields = row.split()
            host_hex, port_hex = fields[2].split(":")
            if int(port_hex, 16) != port:
                continue
            # /proc prints the address as host-order 32-bit words
            raw = bytes.fromhex(host_hex)
            packed = b"".join(raw[i : i + 4][::-1] for i in range(0, width, 4))
            address = ipaddress.ip_address(packed)
            if isinstance(address, ipaddress.IPv6Address) and address.ipv4_mapped:
                address = address.ipv4_mapped
            if address in addresses and int(fields[9]):  # 0: no socket left (TIME_WAIT)
                inodes.add(int(fields[9]))
    return inodes


class RtdeLinkWatch:
    """Duplicates of the process's sockets to robot:30004, taken when made (after the
    RTDE interfaces connected); lost() is true from the moment the robot shut one."""

    def __init__(self, robot: str, port: int = RTDE_PORT) -> None:
        inodes = _robot_sockets(robot, port)
        self._fds: list[int] = []
        for name in os.listdir("/proc/self/fd"):
            try:
                target = os.readlink(f"/proc/self/fd/{name}")
            except OSError:
                continue  # closed since the listing (the listing's own descriptor)
            inode = int(target[8:-1]) if target.startswith("socket:[") else 0
            if inode in inodes:  # once each: a socket can have several descriptors
                inodes.discard(inode)
                self._fds.append(os.dup(int(name)))
        self._poll = select.poll()
        for fd in self._fds:
            self._poll.register(fd, _GONE)

    @property
    def watched(self) -> int:
        """How many connections are watched (two: the receive and control interfaces)."""
        return len(self._fds)

    def lost(self) -> bool:
        return bool(self._poll.poll(0))

    def close(self) -> None:
        """Lets go of the duplicates; before ur_rtde disconnects, or the robot would not
        see its connections close."""
        for fd in self._fds:
            os.close(fd)
        self._fds = []
        self._poll = select.poll()
