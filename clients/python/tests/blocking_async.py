"""AsyncClient behind the blocking Client's interface, so that the same tests run
against both clients: an event loop on its own thread, and wrappers that hand each
call's coroutine to it and wait. Only the waiting is added; every call is the
AsyncClient's own (the tests' sockets, servers and assertions are the same)."""

from __future__ import annotations

import asyncio
import inspect
import threading
import weakref
from collections.abc import Callable, Coroutine, Iterator
from typing import Any

import hapticd
from hapticd import AsyncClient, AsyncSubscription, Telemetry

# No wait here is left unbounded: the clients' own timeouts end every call long before.
RESULT_TIMEOUT_S = 300


class LoopThread:
    """An asyncio event loop running on a daemon thread until close()."""

    def __init__(self) -> None:
        self.loop = asyncio.new_event_loop()
        self._thread = threading.Thread(target=self.loop.run_forever, daemon=True)
        self._thread.start()

    def run(self, coroutine: Coroutine[Any, Any, Any]) -> Any:
        """Runs coroutine on the loop and returns (or raises) what it does."""
        return asyncio.run_coroutine_threadsafe(coroutine, self.loop).result(RESULT_TIMEOUT_S)

    def close(self) -> None:
        """Stops the loop and its thread. Idempotent."""
        if self.loop.is_closed():
            return
        self.loop.call_soon_threadsafe(self.loop.stop)
        self._thread.join(timeout=10)
        self.loop.close()


class BlockingSubscription(Iterator[Telemetry]):
    """An AsyncSubscription read as the blocking Subscription is."""

    def __init__(self, subscription: AsyncSubscription, loop: LoopThread) -> None:
        self._subscription = subscription
        self._loop = loop
        self.subscription_id = subscription.subscription_id

    def __enter__(self) -> BlockingSubscription:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()

    def __next__(self) -> Telemetry:
        return self.next()

    def next(self, timeout_s: float | None = None) -> Telemetry:
        return self._loop.run(self._subscription.next(timeout_s))

    def close(self) -> None:
        self._loop.run(self._subscription.close())


class BlockingAsyncClient:
    """Each AsyncClient method, called and awaited: the blocking Client's interface."""

    def __init__(self, client: AsyncClient, loop: LoopThread, owns_loop: bool = True) -> None:
        object.__setattr__(self, "_client", client)
        object.__setattr__(self, "_loop", loop)
        object.__setattr__(self, "_owns_loop", owns_loop)
        if owns_loop:
            weakref.finalize(self, loop.close)

    def __getattr__(self, name: str) -> Any:
        attribute = getattr(self._client, name)
        if not callable(attribute):
            return attribute
        return self._blocking(attribute)

    def __setattr__(self, name: str, value: Any) -> None:
        setattr(self._client, name, value)

    def _blocking(self, method: Callable[..., Any]) -> Callable[..., Any]:
        def call(*args: Any, **kwargs: Any) -> Any:
            result = method(*args, **kwargs)
            if inspect.isawaitable(result):
                result = self._loop.run(_awaited(result))
            if isinstance(result, AsyncSubscription):
                return BlockingSubscription(result, self._loop)
            return result

        return call

    def __enter__(self) -> BlockingAsyncClient:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, *exc_info: object) -> None:
        if self._loop.loop.is_closed():
            return
        try:
            self._loop.run(self._client.__aexit__(exc_type, *exc_info))
        finally:
            self._finish()

    def close(self) -> None:
        # the loop stays for the calls a test makes after closing (a closed client's
        # errors); it stops when the with block ends or the wrapper is collected
        self._loop.run(self._client.close())

    def _finish(self) -> None:
        """Stops the loop, when it is this wrapper's own."""
        if self._owns_loop:
            self._loop.close()


async def _awaited(awaitable: Any) -> Any:
    return await awaitable


def connect_async_blocking(address: str, **options: Any) -> BlockingAsyncClient:
    """hapticd.connect_async(address, **options) on a loop of its own, wrapped."""
    loop = LoopThread()
    try:
        client = loop.run(hapticd.connect_async(address, **options))
    except BaseException:
        loop.close()
        raise
    return BlockingAsyncClient(client, loop)


# The two ways to connect, by the name the tests' ids show.
CONNECTS: dict[str, Callable[..., Any]] = {
    "blocking": hapticd.connect,
    "asyncio": connect_async_blocking,
}
