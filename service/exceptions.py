"""The exceptions a request can end in, each mapped to an HTTP status in ``service.errors``.

Their own module so that routes, validation, middleware and the jobs runner name them without
importing the worker pool, and the pool raises them without knowing about HTTP.
"""

from __future__ import annotations


class PoolError(Exception):
    """A render could not be served; subclasses map to HTTP statuses in ``service.errors``."""


class PoolBusy(PoolError):
    pass


class PoolClosed(PoolError):
    pass


class RenderTimeout(PoolError):
    pass


class WorkerDied(PoolError):
    pass


class RenderFailed(PoolError):
    """The engine refused or failed the scene; ``kind`` is non_finite, invalid, internal or fields
    (a score's prepared scene is invalid: ``message`` is pydantic's errors as JSON)."""

    def __init__(self, kind: str, message: str):
        super().__init__(message)
        self.kind = kind
        self.message = message


class ClientGone(Exception):
    """The client disconnected while its render waited or ran: nobody to answer."""


class StreamAborted(Exception):
    """A stream failed after its header was sent: the connection must be closed short."""
