"""Keep glibc from returning freed heap memory to the OS after every control step.

One control step allocates a few MB of short-lived numpy temporaries of 0.1-1 MB each. glibc
serves them by mmap or trims them from the heap top as soon as they are freed, so every step
page-faults its memory in again (docs/performance.md has the cost). Raising M_MMAP_THRESHOLD
to 32 MB and M_TRIM_THRESHOLD to 64 MB keeps that memory in the process (at most ~64 MB
retained). No-op on non-glibc platforms or when the environment variable
DCMPPI_NO_MALLOC_TUNING is set.

It changes the whole process's memory settings, so only the entry points call it: the `dcmppi`
command, the bench's pool and Ray workers and `dcmppi timing`; `import dcmppi` and
`make_controller` leave a user's process alone.
"""

import ctypes
import ctypes.util
import os
import sys

_M_TRIM_THRESHOLD, _M_MMAP_THRESHOLD = -1, -3
_done = False


def tune_malloc():
    """Apply the thresholds once per process; returns True when they were applied."""
    global _done
    if _done or not sys.platform.startswith("linux") or os.environ.get("DCMPPI_NO_MALLOC_TUNING"):
        return False
    _done = True
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
        mallopt = libc.mallopt
    except (OSError, AttributeError):  # not glibc
        return False
    return bool(mallopt(_M_MMAP_THRESHOLD, 32 << 20)) and bool(mallopt(_M_TRIM_THRESHOLD, 64 << 20))
