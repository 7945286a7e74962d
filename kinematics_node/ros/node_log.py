"""Our nodes' log: the lines their service logic reports (`log_lines`), and problems that repeat
at a message's rate, logged at most once per period each (`ThrottledWarnings`). No rclpy import:
`logger` is an rclpy logger (`node.get_logger()`), or anything with `error`, `warning`, `info`.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Iterable
from typing import Any

#: Seconds between two log lines about the same problem.
WARN_PERIOD = 5.0


def log_lines(logger: Any, lines: Iterable[tuple[str, str]]) -> None:
    """Log each (level, text) of `lines` ("error", "warn" or anything else: info), as a service's
    `take_log()` gives them."""
    for level, text in lines:
        # one call site per severity: rclpy refuses a call site whose severity changes
        if level == "error":
            logger.error(text)
        elif level == "warn":
            logger.warning(text)
        else:
            logger.info(text)


class ThrottledWarnings:
    """Log each distinct problem (or `kind` of problem) at most once per `period_s` seconds, as a
    warning saying so: at 1 kHz a bad stream would otherwise flood the log, and rclpy's own
    throttle (per call site) would hide all problems but one."""

    def __init__(
        self,
        logger: Any,
        period_s: float = WARN_PERIOD,
        clock: Callable[[], float] = time.monotonic,
        kinds: int = 256,
    ) -> None:
        self._logger, self._period, self._clock, self._kinds = logger, period_s, clock, kinds
        self._last: dict[str, float] = {}  # problem or kind -> when it was last logged

    def __call__(self, problem: str, kind: str | None = None) -> None:
        """Warn about `problem` unless the same problem (or one of the same `kind`) was logged
        less than the period ago; past `kinds` distinct keys, all are forgotten."""
        now = self._clock()
        key = problem if kind is None else kind
        if now - self._last.get(key, -math.inf) < self._period:
            return
        if len(self._last) >= self._kinds:
            self._last.clear()
        self._last[key] = now
        self._logger.warning(f"{problem} (repeats are not logged for {self._period:g} s)")
