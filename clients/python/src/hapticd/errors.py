"""The exceptions hapticd raises: every one is a HapticdError.

    HapticdError
    ├── LocalError         you misused the API: a bad argument (named, with its value)
    ├── RemoteError        the server answered a request with an Error reply
    ├── ProtocolError      the server (or whatever is on the other end) broke the protocol
    ├── ConnectionClosed   the connection ended (the server hung up or died), or could
    │                      not be made; every later call on it says so again, and why
    ├── SessionEnded       the server says a device session has ended (closed or timed
    │                      out): its states are no longer rendered
    └── Timeout            no answer within the timeout the caller gave (only then)

LocalError is also a ValueError and Timeout a TimeoutError, so code that catches the
built-in kinds keeps working. Wrapped exceptions are chained (`raise ... from exc`).
"""

from __future__ import annotations


class HapticdError(Exception):
    """Base class of every error hapticd raises."""


class LocalError(HapticdError, ValueError):
    """The caller misused the API (a bad argument or keyword, a client it closed);
    nothing was sent."""


class RemoteError(HapticdError):
    """The server refused a request: `code` is the Error.Code name (e.g. "NOT_FOUND"),
    `code_value` its number and `message` the server's text, which names the problem."""

    def __init__(self, code: str, code_value: int, message: str, request: str = "") -> None:
        self.code = code
        self.code_value = code_value
        self.message = message
        self.request = request
        where = f"{request}: " if request else ""
        super().__init__(f"{where}server error {code}: {message}")


class ProtocolError(HapticdError):
    """The peer broke the protocol: a malformed or oversized frame, a reply of the wrong
    kind, a datagram whose tag does not verify."""


class ConnectionClosed(HapticdError):
    """The connection could not be made, or ended while a reply was awaited."""


class SessionEnded(HapticdError):
    """The server answered a device's state saying its session has ended: `reason` is
    "closed" (CloseSession) or "timed_out" (silent for its timeout)."""

    def __init__(self, session_id: int, reason: str) -> None:
        self.session_id = session_id
        self.reason = reason
        super().__init__(f"session {session_id:08x} has ended on the server ({reason})")


class Timeout(HapticdError, TimeoutError):
    """No answer arrived within the caller's timeout."""


class QuaternionOrderWarning(UserWarning):
    """A rotation was given as a quaternion that may be in scipy's (x, y, z, w) order;
    hapticd reads (w, x, y, z) (the rule: _validate.hint_quaternion_order). A warning,
    not an error: the value is used as given."""
