"""The ``guitar-synth`` command line: ``render``, ``scene`` and ``serve`` (``cli.main``)."""
