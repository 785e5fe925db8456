"""What Client and DeviceSession share as context managers: leaving the with block
closes; while an exception is already on its way out, a failure to clean up is not
raised over it (the exception in flight says more)."""

from __future__ import annotations

from hapticd.errors import HapticdError


class ClosesOnExit:
    """A mixin: __exit__ calls close(), which the class defines."""

    def close(self) -> None:
        raise NotImplementedError

    def __exit__(self, exc_type: type[BaseException] | None, *exc_info: object) -> None:
        if exc_type is None:
            self.close()
            return
        try:
            self.close()
        except HapticdError:
            pass
