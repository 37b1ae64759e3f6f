"""Small least-recently-used caches, optionally one per thread.

The mesh structures of :mod:`gaocvx.mixed`, their factors of the constant
Hessian, and the compiled parametric programs of :mod:`gaocvx.convex` are
kept for the last few keys, so that the scenes of a sweep share them.  A
compiled program holds the parameter values of the scene being solved and a
structure fills its lazy parts on first use, so threads (a threaded Dask
worker) keep caches of their own.

Examples
--------
>>> cache = LRU(2)
>>> cache.put("a", 1), cache.put("b", 2), cache.put("c", 3)
(1, 2, 3)
>>> cache.get("a") is None, cache.get("c")
(True, 3)
"""

from __future__ import annotations

import collections
import threading

__all__ = ["LRU"]


class LRU:
    """A mapping that keeps its ``size`` most recently used entries.

    Parameters
    ----------
    size : int
    per_thread : bool
        Give every thread a cache of its own.
    """

    def __init__(self, size: int, per_thread: bool = False):
        self.size = size
        self._local = threading.local() if per_thread else None
        self._shared = None if per_thread else collections.OrderedDict()

    def _entries(self) -> collections.OrderedDict:
        if self._local is None:
            return self._shared
        if not hasattr(self._local, "entries"):
            self._local.entries = collections.OrderedDict()
        return self._local.entries

    def get(self, key):
        """The entry of ``key`` (now the most recent), or None."""
        entries = self._entries()
        value = entries.get(key)
        if value is not None:
            entries.move_to_end(key)
        return value

    def put(self, key, value):
        """Store ``value`` under ``key``, dropping the least recent beyond ``size``; returns it."""
        entries = self._entries()
        entries[key] = value
        entries.move_to_end(key)
        while len(entries) > self.size:
            entries.popitem(last=False)
        return value

    def clear(self) -> None:
        """Forget every entry (of this thread's cache)."""
        self._entries().clear()
