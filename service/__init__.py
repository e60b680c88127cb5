"""HTTP service for the guitar engine: FastAPI app (``service.app:app``), settings, worker pool."""
