"""JSON-lines logging for the service's own loggers (``service.*``).

One object per line, so that a log shipper can parse it without a grammar: ``ts``, ``level``,
``logger``, ``msg`` and whatever a call passes as ``extra={"fields": {...}}``.
"""

from __future__ import annotations

import json
import logging
import sys
import time

_HANDLER_NAME = "service-json"


class JsonFormatter(logging.Formatter):
    def format(self, record: logging.LogRecord) -> str:
        line = {
            "ts": time.strftime("%Y-%m-%dT%H:%M:%S", time.gmtime(record.created))
            + f".{int(record.msecs):03d}Z",
            "level": record.levelname.lower(),
            "logger": record.name,
            "msg": record.getMessage(),
        }
        fields = getattr(record, "fields", None)
        if isinstance(fields, dict):
            line.update(fields)
        if record.exc_info:
            line["exc"] = self.formatException(record.exc_info)
        return json.dumps(line, default=str)


def setup_logging(level: str = "INFO") -> None:
    """Attach one JSON handler (stderr) to the ``service`` logger; idempotent."""
    logger = logging.getLogger("service")
    logger.setLevel(level.upper())
    if not any(h.get_name() == _HANDLER_NAME for h in logger.handlers):
        handler = logging.StreamHandler(sys.stderr)
        handler.set_name(_HANDLER_NAME)
        handler.setFormatter(JsonFormatter())
        logger.addHandler(handler)
    logger.propagate = False
