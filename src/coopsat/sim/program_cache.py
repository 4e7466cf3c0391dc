"""A process's compiled programs by key: a bounded least-recently-used map, safe under threads.

Every read and write of the map and of its order holds one lock, so threads that run the
engine at the same time never see a half-updated map, lose an entry or grow it past its bound.
Compiling is not done under the lock (:meth:`ProgramCache.get_or_make`): it takes seconds, and
runs of other structures should not wait for it. Two threads that miss the same key at once
then both compile; the first to finish stores its programs and the other uses those and drops
its own, so every caller of a key gets the same programs. The duplicate compile is accepted as
the price of a lock that is never held for long.
"""

import threading
from collections import OrderedDict

_MISSING = object()


class ProgramCache:
    """A bounded map of compiled programs, least recently used first; every method takes a lock.

    Parameters
    ----------
    max_size : int
        Entries kept; storing one more drops the least recently used.
    """

    def __init__(self, max_size):
        if max_size < 1:
            raise ValueError(f"ProgramCache: max_size must be at least 1, not {max_size}")
        self.max_size = int(max_size)
        self._lock = threading.Lock()
        self._items = OrderedDict()

    def get(self, key, default=None):
        """The value of ``key`` (now the most recently used), or ``default``."""
        with self._lock:
            value = self._items.get(key, _MISSING)
            if value is _MISSING:
                return default
            self._items.move_to_end(key)
            return value

    def put(self, key, value):
        """Store ``value`` for ``key`` unless another thread stored one first; return the one kept
        (now the most recently used), dropping the least recently used beyond :attr:`max_size`."""
        with self._lock:
            kept = self._items.setdefault(key, value)
            self._items.move_to_end(key)
            while len(self._items) > self.max_size:
                self._items.popitem(last=False)
            return kept

    def get_or_make(self, key, make):
        """The value of ``key``, made by ``make()`` (outside the lock) and stored on a miss."""
        value = self.get(key, _MISSING)
        if value is _MISSING:
            value = self.put(key, make())
        return value

    def clear(self):
        """Drop every entry."""
        with self._lock:
            self._items.clear()

    def keys(self):
        """The keys, least recently used first (a snapshot)."""
        with self._lock:
            return list(self._items)

    def values(self):
        """The values, least recently used first (a snapshot)."""
        with self._lock:
            return list(self._items.values())

    def __getitem__(self, key):
        """The value of ``key``, leaving the order as it is (``KeyError`` when absent)."""
        with self._lock:
            return self._items[key]

    def __contains__(self, key):
        with self._lock:
            return key in self._items

    def __iter__(self):
        return iter(self.keys())

    def __len__(self):
        with self._lock:
            return len(self._items)
