"""A progress log for long runs: one line per step on stderr, with the time since the start and,
for counted steps, an estimate of the time left."""

from __future__ import annotations

import sys
import time
from typing import TextIO

__all__ = ["StepLog"]


class StepLog:
    """Callable that writes ``[elapsed] message`` lines.

    ``log.counted(k, n, message)`` marks the start of step ``k`` of ``n`` and adds the time left
    at the mean pace of the steps done so far.

    Examples
    --------
    >>> import io
    >>> stream = io.StringIO()
    >>> log = StepLog(stream)
    >>> log("sampling ...")
    >>> stream.getvalue().endswith("s] sampling ...\\n")
    True
    """

    def __init__(self, stream: TextIO | None = None) -> None:
        self.stream = stream
        self.start = time.perf_counter()

    @property
    def elapsed(self) -> float:
        return time.perf_counter() - self.start

    def __call__(self, message: str) -> None:
        stream = self.stream if self.stream is not None else sys.stderr
        print(f"[{self.elapsed:7.1f} s] {message}", file=stream, flush=True)

    def counted(self, index: int, total: int, message: str) -> None:
        """Step ``index`` (1-based) of ``total`` starts now."""
        done = index - 1
        if done > 0 and total > done:
            left = self.elapsed / done * (total - done)
            message = f"{message} (about {left:.0f} s left)"
        self(message)
