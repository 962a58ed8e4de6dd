"""Bounded per-process memos of expensive job inputs (compiled estimators, truth runs, logs).

A :class:`Memo` keeps the ``size`` most recently used values; every memo is registered, so
:func:`clear_all` empties them at once (the tests do between modules)."""

from __future__ import annotations

from collections import OrderedDict
from collections.abc import Callable, Hashable
from typing import Any

_ALL: list[Memo] = []


class Memo:
    """``memo.get(key, make)``: the value for ``key``, made by ``make()`` the first time; the least
    recently used value is dropped beyond ``size`` entries."""

    def __init__(self, size: int) -> None:
        self.size = size
        self._values: OrderedDict[Hashable, Any] = OrderedDict()
        _ALL.append(self)

    def get(self, key: Hashable, make: Callable[[], Any]) -> Any:
        if key in self._values:
            self._values.move_to_end(key)
            return self._values[key]
        value = make()
        self._values[key] = value
        if len(self._values) > self.size:
            self._values.popitem(last=False)
        return value

    def __len__(self) -> int:
        return len(self._values)

    def clear(self) -> None:
        self._values.clear()


def clear_all() -> None:
    """Empty every memo of this process."""
    for memo in _ALL:
        memo.clear()
