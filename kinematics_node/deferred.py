"""Service responses sent after the callback has returned, without a coroutine (no rclpy here).

Why not an `async` callback that awaits the answer: rclpy's executors (Humble through Rolling)
await a Future by polling. Every pending coroutine task is resumed on every turn of the executor,
so 4 `compute_ik` requests awaiting their IK workers cost 4 task resumes per joint_states message,
and each answer costs one more turn to resume its task. Measured with
`benchmarks/node_benchmark.py` at 500 Hz joint_states with 4 IK clients: a third of the node's
CPU went to that polling and to the extra turns.

How: rclpy's Python executors (from Foxy through Jazzy and Rolling) send a service's answer by
calling `service.send_response(response, header)` (public API) right after the callback returns. `DeferredResponses` takes that method's
place on one service object. The callback marks its response as held (`hold`) before returning
it; for a held response, `send_response` only records the request's header. When the answer is
known, the caller fills the response and calls `release`, which sends it with that header. A
response that is not held is sent at once, as before. If `release` comes before the executor's
`send_response` (not possible with one executor thread, handled anyway), the response goes out
when the header arrives.

Not thread-safe: `hold`, `release` and the executor's `send_response` all run in the node's one
executor thread.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from typing import Any

_log = logging.getLogger(__name__)

_NO_HEADER = object()


class _Held:
    __slots__ = ("response", "header", "released")

    def __init__(self, response: Any) -> None:
        self.response = response
        self.header: Any = _NO_HEADER
        self.released = False


class DeferredResponses:
    """Lets the callbacks of `service` answer later (see the module docstring).

    Args:
        service: an rclpy `Service` (anything with `send_response(response, header)`).
        on_send_error: called with the exception when sending a released response fails (the
            client is gone, the node is shutting down); the default logs it.
    """

    def __init__(
        self, service: Any, on_send_error: Callable[[BaseException], None] | None = None
    ) -> None:
        self._send: Callable[[Any, Any], None] = service.send_response
        self._held: dict[int, _Held] = {}  # id(response) -> its record (which keeps it alive)
        self._on_send_error = on_send_error or (
            lambda exc: _log.warning("a deferred service response could not be sent: %r", exc)
        )
        service.send_response = self._send_or_hold

    def __len__(self) -> int:
        """Responses held and not yet sent."""
        return len(self._held)

    def hold(self, response: Any) -> None:
        """Mark `response`, which the callback is about to return, as answered later."""
        self._held[id(response)] = _Held(response)

    def release(self, response: Any) -> None:
        """Send the held `response` (filled in by now) with its request's header."""
        held = self._held.get(id(response))
        if held is None or held.response is not response:
            raise KeyError("release() of a response that is not held")
        if held.header is _NO_HEADER:
            held.released = True  # the executor has not sent it yet: it goes out then
            return
        del self._held[id(response)]
        self._deliver(response, held.header)

    def _send_or_hold(self, response: Any, header: Any) -> None:
        held = self._held.get(id(response))
        if held is None or held.response is not response:
            self._send(response, header)  # answered in the callback: send it now
        elif held.released:
            del self._held[id(response)]
            self._deliver(response, header)
        else:
            held.header = header

    def _deliver(self, response: Any, header: Any) -> None:
        try:
            self._send(response, header)
        except Exception as exc:  # noqa: BLE001 - one lost answer must not stop the others
            self._on_send_error(exc)
