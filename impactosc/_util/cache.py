"""Objects built once per key and shared: compiled integrators and numeric forms of a system's structure."""

from __future__ import annotations

import threading
from collections.abc import Callable, Hashable
from typing import Generic, TypeVar

__all__ = ["BuiltOnce"]

T = TypeVar("T")


class BuiltOnce(Generic[T]):
    """A store of objects each built once for its key (e.g. a system's structure and a tolerance).

    Building may take seconds (heyoka compiles), so two threads that ask for the same key at
    once get one object, built once; a key already built is read without the lock. Nothing
    is evicted: the keys are the structures a process works with.
    """

    def __init__(self):
        self._store: dict[Hashable, T] = {}
        self._lock = threading.Lock()

    def get(self, key: Hashable, build: Callable[[], T]) -> T:
        """The object of ``key``; ``build()`` makes it the first time."""
        found = self._store.get(key)
        if found is None:
            with self._lock:
                found = self._store.get(key)
                if found is None:
                    found = self._store[key] = build()
        return found
