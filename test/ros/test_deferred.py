"""`DeferredResponses`: responses held past their callback and sent with their request's header."""

from __future__ import annotations

import time
from typing import Any

import pytest

from kinematics_node.ros.deferred import DeferredResponses, waited_since_sent


class FakeService:
    """What an rclpy executor sees of a Service: `send_response(response, header)`."""

    def __init__(self, fail_on: Any = None) -> None:
        self.sent: list[tuple[Any, Any]] = []
        self.fail_on = fail_on

    def send_response(self, response: Any, header: Any) -> None:
        if response is self.fail_on:
            raise RuntimeError("client gone")
        self.sent.append((response, header))


class Response:
    """Equal content, distinct objects: held responses must be told apart by identity."""

    def __init__(self) -> None:
        self.success = False

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Response) and other.success == self.success

    __hash__ = None  # type: ignore[assignment]  # unhashable, as ROS messages are


def executor_turn(service: FakeService, callback: Any, header: Any) -> None:
    """What rclpy does with a request: call back, then send what the callback returned."""
    service.send_response(callback(Response()), header)


def test_a_response_not_held_is_sent_at_once():
    service = FakeService()
    DeferredResponses(service)
    executor_turn(service, lambda r: r, "h1")
    assert [h for _, h in service.sent] == ["h1"]


def test_a_held_response_goes_out_on_release_with_its_own_header():
    service = FakeService()
    deferred = DeferredResponses(service)
    held: list[Response] = []

    def callback(response: Response) -> Response:
        deferred.hold(response)
        held.append(response)
        return response

    executor_turn(service, callback, "h1")
    executor_turn(service, callback, "h2")
    assert service.sent == [] and len(deferred) == 2
    held[1].success = True
    deferred.release(held[1])
    assert service.sent == [(held[1], "h2")] and service.sent[0][0].success
    deferred.release(held[0])
    assert service.sent[1] == (held[0], "h1") and service.sent[1][0] is held[0]
    assert len(deferred) == 0


def test_a_release_before_the_executor_sends_goes_out_with_the_header():
    service = FakeService()
    deferred = DeferredResponses(service)

    def callback(response: Response) -> Response:
        deferred.hold(response)
        deferred.release(response)  # the answer was known before the callback returned
        return response

    executor_turn(service, callback, "h1")
    assert [h for _, h in service.sent] == ["h1"] and len(deferred) == 0


def test_release_of_a_response_that_is_not_held_is_an_error():
    deferred = DeferredResponses(FakeService())
    with pytest.raises(KeyError, match="not held"):
        deferred.release(Response())
    r = Response()
    deferred.hold(r)
    with pytest.raises(KeyError):
        deferred.release(Response())  # equal, but another object


def test_a_failed_send_is_reported_and_the_others_still_go_out():
    a, b = Response(), Response()
    service = FakeService(fail_on=a)
    errors: list[BaseException] = []
    deferred = DeferredResponses(service, errors.append)
    for response, header in ((a, "ha"), (b, "hb")):
        deferred.hold(response)
        service.send_response(response, header)
    deferred.release(a)
    deferred.release(b)
    assert [type(e) for e in errors] == [RuntimeError]
    assert service.sent == [(b, "hb")] and len(deferred) == 0


def test_on_header_starts_the_work_when_the_header_arrives_and_may_release_at_once():
    service = FakeService()
    deferred = DeferredResponses(service)
    seen: list[Any] = []

    def start(response: Response, header: Any) -> None:
        seen.append(header)
        assert response not in [r for r, _ in service.sent]  # not sent before its work starts
        if header == "now":
            response.success = True
            deferred.release(response)

    def callback(response: Response) -> Response:
        deferred.hold(response, on_header=lambda header: start(response, header))
        return response

    executor_turn(service, callback, "now")
    assert seen == ["now"] and len(service.sent) == 1 and service.sent[0][0].success
    executor_turn(service, callback, "later")
    assert seen == ["now", "later"] and len(service.sent) == 1 and len(deferred) == 1
    held = next(iter(deferred._held.values())).response
    deferred.release(held)
    assert service.sent[1] == (held, "later") and len(deferred) == 0


def test_a_failing_on_header_still_answers_the_request(caplog):
    service = FakeService()
    deferred = DeferredResponses(service)

    def callback(response: Response) -> Response:
        deferred.hold(response, on_header=lambda header: 1 / 0)
        return response

    executor_turn(service, callback, "h1")
    assert [h for _, h in service.sent] == ["h1"] and len(deferred) == 0
    assert "ZeroDivisionError" in caplog.text


class Header:
    def __init__(self, source_timestamp: Any) -> None:
        self.source_timestamp = source_timestamp


@pytest.mark.parametrize(
    ("stamp", "expected"),
    [(10**18, 0.25), (10**18 + 250_000_000, 0.0), (10**18 + 10**9, 0.0), (0, 0.0), (None, 0.0)],
)
def test_waited_since_sent_reads_the_source_timestamp(stamp, expected):
    now = 10**18 + 250_000_000
    assert waited_since_sent(Header(stamp), now_ns=now) == pytest.approx(expected, abs=1e-12)


def test_waited_since_sent_is_zero_without_a_timestamp_and_the_age_with_one():
    assert waited_since_sent(object()) == 0.0
    assert 0.005 <= waited_since_sent(Header(time.time_ns() - 5_000_000)) < 1.0
