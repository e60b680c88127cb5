"""The scripts whose tables the README and docs/ quote, each run as ``python -m benchmarks.NAME``;
``make bench`` (``benchmarks.run_all``) runs them all and writes their output to benchmarks/out/.

What the tests share with these scripts (scene builders, physics checks, measurements, random
scenes) is ``engine.testing``; instruments for changing the engine are ``tools/``.
"""
