"""The records of a run of the exact n-DOF backend: its events in order, and the compiled loop's buffers."""

from __future__ import annotations

import numpy as np

from ...results._mechanical import event_dtype
from ._modes import ENTER, IMPACT, LEAVE, LIFT, RELEASE, SLIP_END, STICK

__all__ = ["EventLog", "KIND_NAMES", "buffers"]

#: Event names of the guard kinds the compiled loop records (indexed by the kind).
KIND_NAMES = np.array([{IMPACT: "impact", ENTER: "contact_start", LEAVE: "contact_end", LIFT: "lift",
                        RELEASE: "release", SLIP_END: "reversal", STICK: "stick"}.get(k, "") for k in range(7)])


class EventLog:
    """The events of a run: single ones from the Python rule, blocks from the compiled loop, in order."""

    def __init__(self, n: int):
        self.dtype = event_dtype(n)
        self.items: list = []  # event tuples and structured arrays
        self.count = 0

    def __len__(self) -> int:
        return self.count

    def append(self, event: tuple) -> None:
        self.items.append(event)
        self.count += 1

    def block(self, t, kinds, index, q, v) -> None:
        block = np.empty(t.shape[0], dtype=self.dtype)
        block["t"], block["kind"], block["index"], block["q"], block["v"] = t, kinds, index, q, v
        self.items.append(block)
        self.count += t.shape[0]

    def array(self) -> np.ndarray:
        out: list[np.ndarray] = []
        singles: list[tuple] = []
        for item in self.items:
            if isinstance(item, np.ndarray):
                if singles:
                    out.append(np.array(singles, dtype=self.dtype))
                    singles = []
                out.append(item)
            else:
                singles.append(tuple(item))
        if singles:
            out.append(np.array(singles, dtype=self.dtype))
        return np.concatenate(out) if out else np.empty(0, dtype=self.dtype)


def buffers(held: list, n: int, cap: int) -> tuple:
    """Event and piece buffers of the compiled loop, kept in ``held`` and reused while large enough:
    ``ev_t, ev_kind, ev_index, ev_q, ev_v, pc_t, pc_mode, pc_q, pc_v``."""
    if not held or held[0].shape[0] < cap:
        held[:] = (np.empty(cap), np.empty(cap, dtype=np.int64), np.empty(cap, dtype=np.int64), np.empty((cap, n)),
                   np.empty((cap, n)), np.empty(cap + 1), np.empty(cap + 1, dtype=np.int64), np.empty((cap + 1, n)),
                   np.empty((cap + 1, n)))
    return (*(x[:cap] for x in held[:5]), *(x[:cap + 1] for x in held[5:]))
