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

The header also says when the client sent its request (`source_timestamp`), which the callback
cannot see: `hold(response, on_header)` calls `on_header(header)` as soon as the header arrives
(right after the callback, in the same turn of the executor), so that the work can start knowing
how long the request waited (`waited_since_sent`). `on_header` may `release` the response at once.

Not thread-safe: `hold`, `release` and the executor's `send_response` all run in the node's one
executor thread.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from typing import Any

_log = logging.getLogger(__name__)

_NO_HEADER = object()


def waited_since_sent(header: Any, now_ns: int | None = None) -> float:
    """How long ago [s] the client sent the request of `header` (rmw's service info; its
    `source_timestamp` is the client's system clock, in ns): 0.0 when the header has no
    timestamp, or when it lies in the future (a client's clock ahead of this machine's)."""
    sent = getattr(header, "source_timestamp", 0)
    if not isinstance(sent, int) or sent <= 0:
        return 0.0
    now = time.time_ns() if now_ns is None else now_ns
    return max(now - sent, 0) * 1e-9


class _Held:
    __slots__ = ("response", "header", "released", "on_header")

    def __init__(self, response: Any, on_header: Callable[[Any], None] | None) -> None:
        self.response = response
        self.header: Any = _NO_HEADER
        self.released = False
        self.on_header = on_header


class DeferredResponses:
    """Lets the callbacks of `service` answer later (see the module docstring).

    Args:
        service: an rclpy `Service` (anything with `send_response(response, header)`).
        on_send_error: called with the exception when sending a released response fails (the
            client is gone, the node is shutting down); the default logs it.
    """

    def __init__(
        self, service: Any, on_send_error: Callable[[BaseException], object] | None = None
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

    def hold(self, response: Any, on_header: Callable[[Any], None] | None = None) -> None:
        """Mark `response`, which the callback is about to return, as answered later;
        `on_header(header)` is called when its request's header arrives. Should `on_header` raise,
        the response is sent as it is then (and the error logged): no request is left without
        an answer."""
        self._held[id(response)] = _Held(response, on_header)

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
            if held.on_header is None:
                return
            try:
                held.on_header(header)  # (it may release the response: then it is sent now)
            except Exception:  # noqa: BLE001 - answer the request anyway
                _log.exception("starting the work on a held request failed; answered as it was")
                if self._held.get(id(response)) is held:
                    del self._held[id(response)]
                    self._deliver(response, header)

    def _deliver(self, response: Any, header: Any) -> None:
        try:
            self._send(response, header)
        except Exception as exc:  # noqa: BLE001 - one lost answer must not stop the others
            self._on_send_error(exc)
