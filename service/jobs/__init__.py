"""Jobs: renders that outlive their request and survive a restart of the service.

``store`` (SQLite and the result files), ``runner`` (queued jobs -> the worker pool -> files),
``routes`` (the HTTP resource ``/jobs``).  API.md, "Jobs and batches", is the contract.
"""

from .routes import install, router
from .runner import JobRunner
from .store import Store

__all__ = ["JobRunner", "Store", "install", "router"]
