"""A stop signal that comes while a node process is still starting: the installed executables
(`scripts/`) note SIGINT and SIGTERM from their first line on, until `spin` puts the node's own
handlers in their place (no import here but the standard library's, so that this is in place
before numpy, scipy and rclpy load).

Why: those imports take up to a second or two on a loaded machine, and a supervisor may stop the
process meanwhile (launch shutting down, `processes.stop_nodes`, Ctrl-C). With Python's default
handlers SIGINT ended it with a traceback and status -2 (killed by SIGINT), or with status 1 when
the KeyboardInterrupt landed inside numpy's C extensions, which turn it into an ImportError, and
SIGTERM killed it (-15). A stop asked for before the node existed is a clean stop all the same:
status 0, as `spin` gives after start-up. As there, any error after a noted signal is part of
stopping (the live test_node_stop sends SIGINT at random moments of start-up).
"""

from __future__ import annotations

import signal
from collections.abc import Callable
from types import FrameType


class EarlyStop:
    """Notes SIGINT and SIGTERM from its creation on (each raises KeyboardInterrupt, to cut the
    imports short); `run` gives 0 for whatever ends the process after one."""

    def __init__(self) -> None:
        self.noted: list[int] = []
        for s in (signal.SIGINT, signal.SIGTERM):
            signal.signal(s, self._note)

    def _note(self, signum: int, frame: FrameType | None) -> None:
        self.noted.append(signum)
        raise KeyboardInterrupt

    def run(self, main: Callable[[], int]) -> int:
        """`main()`'s status; 0 when it raises after a noted signal (a stop while starting). A
        `SystemExit` passes, whatever the signals."""
        try:
            return main()
        except SystemExit:
            raise
        except BaseException:
            if not self.noted:
                raise
            return 0
