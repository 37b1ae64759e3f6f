"""How much memory a solve needs, and how much there is.

A mesh that does not fit is refused before any work is done, with the
numbers, instead of swapping for minutes or being killed.  The estimates come
from the peak resident memory (Linux ``VmHWM``) above the imported package,
measured for a Gao beam (P1, uniform load), per element:

- newton: 4.5 kB (no contact), 8.0 kB (foundation), 9.6 kB (obstacle) at
  32768 elements; 4.4, 7.8 and 9.3 kB at 262144;
- convex (Clarabel): 41 kB (foundation) and 35 kB (obstacle) at 32768
  elements, 39 kB at 131072 (foundation), 165 kB at 512 (fixed costs);
- cvm (matrix-free projected Newton, and the Newton ground truth of its
  verdict): 6.3 kB at 4096 and 6.5 kB at 16384 elements (Gao P1, no contact).

The constants below round these up by about a quarter.  The estimates are
rough on purpose (within a factor of about two): they exist to refuse meshes
that cannot fit, not to plan around the last megabyte.

Examples
--------
>>> estimate_memory(1024, "newton", None) < estimate_memory(1024, "convex", "obstacle")
True
>>> estimate_memory(100_000, "newton", "foundation") / 1e9
1.05
"""

from __future__ import annotations

import os

__all__ = ["estimate_memory", "available_memory", "max_elements_that_fit", "check_memory"]

# Bytes per element (linear part) by method and contact, from the measures above,
# rounded up by about a quarter.
_PER_ELEMENT = {
    "newton": {None: 6e3, "foundation": 1.0e4, "obstacle": 1.2e4},
    "convex": {None: 7e4, "foundation": 7e4, "obstacle": 6e4},
    "cvm": {None: 8e3, "foundation": 1.2e4, "obstacle": 1.2e4},
}
# Fixed overhead of a solve beyond the imported package (matrices' index arrays,
# compiled programs, solver workspaces at small sizes).
_BASE = 50e6


def estimate_memory(elements: int, method: str = "auto", contact: str | None = None) -> float:
    """Rough peak memory [bytes] of one solve on a mesh of ``elements`` elements.

    Parameters
    ----------
    elements : int
        Number of elements (including nodes inserted at point forces).
    method : str
        ``"global"`` is estimated as ``"convex"`` (below the convexity limit it
        is the convex program; above it, its meshes are capped far below where
        memory matters); ``"auto"`` and any other method as Newton (what
        ``auto`` chooses below the limit).
    contact : {None, "foundation", "obstacle"}

    Returns
    -------
    float
        Bytes above the imported package.
    """
    n = float(elements)
    table = _PER_ELEMENT.get("convex" if method == "global" else method, _PER_ELEMENT["newton"])
    per = table.get(contact, max(table.values()))
    total = _BASE + per * n
    return total


def _read_int(path: str) -> int | None:
    try:
        with open(path) as fh:
            text = fh.read().strip()
    except OSError:
        return None
    return int(text) if text.isdigit() else None


# Estimates below this are not checked against the available memory (see check_memory).
SMALL = 64e6


def available_memory() -> float | None:
    """Memory [bytes] a solve may use now, or None when it cannot be told.

    The kernel's ``MemAvailable`` (Linux), else the free physical pages, and
    no more than what a cgroup (container) limit leaves.
    """
    avail = None
    try:
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    avail = float(line.split()[1]) * 1024
                    break
    except OSError:
        pass
    if avail is None:
        try:
            avail = float(os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"))
        except (ValueError, OSError, AttributeError):
            avail = None
    # cgroup v2, then v1: the container's limit minus what it already uses.
    for limit_file, usage_file in (("/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory.current"),
                                   ("/sys/fs/cgroup/memory/memory.limit_in_bytes",
                                    "/sys/fs/cgroup/memory/memory.usage_in_bytes")):
        limit, usage = _read_int(limit_file), _read_int(usage_file)
        if limit is not None and usage is not None and limit < 1 << 60:
            room = float(max(limit - usage, 0))
            avail = room if avail is None else min(avail, room)
            break
    return avail


def max_elements_that_fit(method: str = "auto", contact: str | None = None,
                          available: float | None = None) -> int | None:
    """The largest mesh whose estimate fits in ``available`` bytes (default: now).

    None when the available memory cannot be told.
    """
    avail = available_memory() if available is None else available
    if avail is None:
        return None
    lo, hi = 0, 1
    while estimate_memory(hi, method, contact) <= avail and hi < 1 << 40:
        hi *= 2
    while hi - lo > 1:  # the estimate grows with the mesh: bisect
        mid = (lo + hi) // 2
        if estimate_memory(mid, method, contact) <= avail:
            lo = mid
        else:
            hi = mid
    return lo


def check_memory(elements: int, method: str, contact: str | None, key: str, got) -> None:
    """Raise SceneError(key, ...) when the estimate exceeds the available memory.

    A solve whose estimate is under :data:`SMALL` is not checked: the
    interpreter with numpy, scipy and cvxpy loaded already holds more, and
    reading the kernel's counters would cost a sweep of small scenes a quarter
    of a millisecond per value.
    """
    need = estimate_memory(elements, method, contact)
    if need < SMALL:
        return
    avail = available_memory()
    if avail is not None and need > avail:
        from .errors import SceneError
        raise SceneError(key, f"{elements} elements need about {need / 1e9:.3g} GB of memory "
                         f"({method}), more than the {avail / 1e9:.3g} GB available", got)
