"""glibc's allocator tuned for image-size arrays streamed through one process."""
from __future__ import annotations

#: glibc's mallopt parameter: allocations of at least this many bytes are mapped afresh and
#: given back to the system when freed
_M_MMAP_THRESHOLD = -3
_malloc_fixed = False
_libc = None  # glibc, once found (None: not glibc)


def _glibc():
    global _libc
    if _libc is None:
        import ctypes
        import ctypes.util

        name = ctypes.util.find_library("c")
        _libc = ctypes.CDLL(name) if name else False
    return _libc or None


def steady_malloc(threshold: int = 4 << 20) -> None:
    """Fix glibc's mmap threshold (once per process) so that freed image-size arrays go back to
    the system. By default the threshold grows with the largest block freed (up to 32 MB), after
    which 2048x1024 arrays come from the heaps of the threads that made them and stay there:
    streaming 40 image sets, resident memory grew from 600 to 880 MB (peak 1021 MB). With the
    threshold fixed at 4 MB it stayed at 370-480 MB (peak 858 MB), for about 5 % more CPU
    (fresh pages); at 1 MB the same, for 10 %; at 16 MB it grew again (490 -> 640 MB). Limiting
    glibc to one arena did not help. Does nothing without glibc."""
    global _malloc_fixed
    if _malloc_fixed:
        return
    _malloc_fixed = True
    try:
        libc = _glibc()
        if libc is not None:
            libc.mallopt(_M_MMAP_THRESHOLD, threshold)
    except (OSError, AttributeError):  # not glibc: its own allocator
        pass


def release_free_memory() -> None:
    """Give the pages glibc holds free in its heaps back to the system (``malloc_trim``): an
    image set's arrays under the mmap threshold and llvmpipe's buffers leave them scattered
    over the heaps of the threads that used them. After each image set: resident memory 360 ->
    270 MB between sets, for a few milliseconds. Does nothing without glibc."""
    try:
        libc = _glibc()
        if libc is not None:
            libc.malloc_trim(0)
    except (OSError, AttributeError):
        pass


