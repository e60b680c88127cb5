"""Who is asking: the identity per-client quotas and fair shares go by.

A request is its API key's client when ``GUITAR_API_KEYS`` lists the key it sends in
``X-API-Key``; any other request (no key, an unknown key, or no keys configured) is its peer
address's client: the host of the TCP connection, which a client cannot choose.  Forwarding
headers (``X-Forwarded-For``) are not trusted: anyone can write them.  Behind a reverse proxy every
peer is the proxy, so give the clients keys.  The identity is a short tag (a key is kept only as a
hash prefix), stored with each job.
"""

from __future__ import annotations

import hashlib
from typing import Any

from .config import Settings

KEY_HEADER = "x-api-key"


def client_id(conn: Any, settings: Settings) -> str:
    """``key:<12 hex>`` or ``peer:<host>`` of a request or websocket (``conn``)."""
    key = conn.headers.get(KEY_HEADER)
    if key and key in settings.api_key_set:
        return "key:" + hashlib.sha256(key.encode()).hexdigest()[:12]
    host = conn.client.host if conn.client is not None else "unknown"
    return f"peer:{host}"
