"""What this machine takes from a real-time thread: how long a thread on ``SCHED_RR``, with nothing
else to run, is kept off its CPU, and the steal time the hypervisor reports meanwhile.

The live worker's audio thread runs on ``SCHED_RR`` (``GUITAR_LIVE_REALTIME_PRIORITY``), ahead of
every normally scheduled process, and sends each block 20 ms before it plays
(``GUITAR_LIVE_LEAD_MS``).  Inside the guest nothing but the kernel's own real-time work can take
the CPU from such a thread; a virtual machine's host can, by running something else on the
physical core (the guest sees it as *steal* time, the eighth figure of a ``cpu`` line of
``/proc/stat``).  A block that loses its CPU for longer than its lead minus its own cost is late
whatever the service does.

For each CPU in turn, one thread pinned to it on ``SCHED_RR`` works as an audio thread does (2 ms
busy, 3 ms asleep: 40 % of the CPU, below the kernel's real-time throttling) and, while busy,
reads the monotonic clock in a tight loop: a gap between two readings is time it did not run.
Printed per CPU: the gaps over 0.5, 2, 5 and 10 ms, the longest, and the steal time over the
run.  Run it with nothing else running (it needs the privilege to set ``SCHED_RR``: root or
``CAP_SYS_NICE``; without it the thread runs with normal scheduling, and says so).

    python -m benchmarks.hiccups [--seconds 30]
"""

from __future__ import annotations

import argparse
import os
import time

BUSY_S = 0.002
IDLE_S = 0.003
TICK_S = 1.0 / os.sysconf("SC_CLK_TCK")  # /proc/stat counts in these


def steal_ticks(cpu: int) -> int | None:
    """The steal time of ``cpu`` so far, in clock ticks (None where the kernel does not say)."""
    with open("/proc/stat") as f:
        for line in f:
            fields = line.split()
            if fields[0] == f"cpu{cpu}":
                return int(fields[8]) if len(fields) > 8 else None
    return None


def gaps_on(cpu: int, seconds: float) -> tuple[list[float], int | None]:
    """The gaps (s) a thread pinned to ``cpu`` saw while busy for ``seconds``, and the steal ticks
    meanwhile."""
    os.sched_setaffinity(0, {cpu})
    gaps: list[float] = []
    s0 = steal_ticks(cpu)
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        last = time.monotonic()
        until = last + BUSY_S
        while last < until:
            now = time.monotonic()
            if now - last > 0.0005:
                gaps.append(now - last)
            last = now
        time.sleep(IDLE_S)
    s1 = steal_ticks(cpu)
    return gaps, (None if s0 is None or s1 is None else s1 - s0)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=30.0, help="per CPU")
    ap.add_argument("--priority", type=int, default=10, help="SCHED_RR priority (0: normal)")
    a = ap.parse_args()
    if not a.seconds > 0 or a.priority < 0:
        ap.error("--seconds must be > 0 and --priority >= 0")
    policy = "normal scheduling"
    if a.priority:
        try:
            os.sched_setscheduler(0, os.SCHED_RR, os.sched_param(a.priority))
            policy = f"SCHED_RR {a.priority}"
        except OSError as exc:
            print(f"SCHED_RR not set ({exc}): normal scheduling")
    cpus = sorted(os.sched_getaffinity(0))
    print(f"\nA thread on {policy}, {BUSY_S * 1e3:g} ms busy / {IDLE_S * 1e3:g} ms asleep, "
          f"{a.seconds:g} s on each CPU; load average before {os.getloadavg()[0]:.2f}\n")
    print("| CPU | gaps > 0.5 ms | > 2 ms | > 5 ms | > 10 ms | longest, ms | steal, % of the run |")
    print("| --- | ---: | ---: | ---: | ---: | ---: | ---: |")
    for cpu in cpus:
        gaps, steal = gaps_on(cpu, a.seconds)
        share = "n/a" if steal is None else f"{100.0 * steal * TICK_S / a.seconds:.1f}"
        print(f"| {cpu} | {len(gaps)} | {sum(g > 0.002 for g in gaps)} | "
              f"{sum(g > 0.005 for g in gaps)} | {sum(g > 0.010 for g in gaps)} | "
              f"{1e3 * max(gaps, default=0.0):.1f} | {share} |", flush=True)


if __name__ == "__main__":
    main()
