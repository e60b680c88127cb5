"""CPU cycles and instructions of the calling thread, from Linux's hardware performance counters.

Seconds of compute move with whatever machine a run gets: on the "same" 2-core virtual machine
the linear string's step of ``benchmarks.speed``'s component table has printed both 75 ns and
168 ns with the same code for that step.  Instructions retired are a property of the compiled code
and the scene (they change when the code does, not when the machine is busy), and cycles do not
move with the clock's frequency; together with the time they say whether a change made the engine
do less work or the machine got faster.

    with Counters() as c:
        ...                      # the work to count
    c.cycles, c.instructions     # None where the machine gives no counters

``perf_event_open(2)`` on the calling thread only (user space, no kernel or hypervisor time), so
the renders of ``benchmarks.speed``, which run in the calling thread, are what is counted.  Many
virtual machines expose no hardware counters, and a kernel may forbid them
(``/proc/sys/kernel/perf_event_paranoid``): then both figures are ``None`` and the tables print a
dash.
"""

from __future__ import annotations

import ctypes
import os
import platform
import struct

# <linux/perf_event.h>
_PERF_TYPE_HARDWARE = 0
_HW_CPU_CYCLES = 0
_HW_INSTRUCTIONS = 1
_ATTR_SIZE_VER0 = 64  # the first published struct perf_event_attr; every kernel accepts it
# flag bits: disabled (0), exclude_kernel (5), exclude_hv (6)
_FLAGS = (1 << 0) | (1 << 5) | (1 << 6)
_IOC_ENABLE = 0x2400
_IOC_DISABLE = 0x2401
_IOC_RESET = 0x2403
_SYSCALL = {"x86_64": 298, "aarch64": 241}

_libc = ctypes.CDLL(None, use_errno=True)


def _open(config: int) -> int | None:
    nr = _SYSCALL.get(platform.machine())
    if nr is None:
        return None
    # type, size, config, sample_period, sample_type, read_format, flags, wakeup_events,
    # bp_type, config1 (64 bytes)
    attr = struct.pack("IIQQQQQIIQ", _PERF_TYPE_HARDWARE, _ATTR_SIZE_VER0, config, 0, 0, 0,
                       _FLAGS, 0, 0, 0)
    buf = ctypes.create_string_buffer(attr, len(attr))
    fd = _libc.syscall(ctypes.c_long(nr), buf, ctypes.c_int(0), ctypes.c_int(-1),
                       ctypes.c_int(-1), ctypes.c_ulong(0))
    return fd if fd >= 0 else None


class Counters:
    """Cycles and instructions retired by the calling thread inside the ``with`` block."""

    def __init__(self) -> None:
        self.cycles: int | None = None
        self.instructions: int | None = None
        self._fds: list[int | None] = []

    def __enter__(self) -> Counters:
        self._fds = [_open(_HW_CPU_CYCLES), _open(_HW_INSTRUCTIONS)]
        for fd in self._fds:
            if fd is not None:
                _libc.ioctl(fd, _IOC_RESET, 0)
                _libc.ioctl(fd, _IOC_ENABLE, 0)
        return self

    def __exit__(self, *exc) -> None:
        values = []
        for fd in self._fds:
            if fd is None:
                values.append(None)
                continue
            _libc.ioctl(fd, _IOC_DISABLE, 0)
            values.append(struct.unpack("q", os.read(fd, 8))[0])
            os.close(fd)
        self.cycles, self.instructions = values


def available() -> bool:
    """Whether this machine gives the calling thread both counters."""
    with Counters() as c:
        pass
    return c.cycles is not None and c.instructions is not None
