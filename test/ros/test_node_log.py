"""kinematics_node.ros.node_log: the nodes' log lines and throttled warnings (no rclpy: a logger
that records stands in for rclpy's)."""

from __future__ import annotations

from kinematics_node.ros.node_log import ThrottledWarnings, log_lines


class Recorder:
    def __init__(self) -> None:
        self.lines: list[tuple[str, str]] = []

    def error(self, text: str) -> None:
        self.lines.append(("error", text))

    def warning(self, text: str) -> None:
        self.lines.append(("warning", text))

    def info(self, text: str) -> None:
        self.lines.append(("info", text))


def test_service_lines_go_to_their_severity():
    logger = Recorder()
    log_lines(logger, [("error", "a"), ("warn", "b"), ("info", "c"), ("note", "d")])
    assert logger.lines == [("error", "a"), ("warning", "b"), ("info", "c"), ("info", "d")]


def test_each_problem_is_warned_about_once_per_period():
    logger, now = Recorder(), [100.0]
    warn = ThrottledWarnings(logger, period_s=5.0, clock=lambda: now[0])
    warn("joint 'a' is NaN")
    warn("joint 'a' is NaN")  # the same, at once: not logged
    warn("joint 'b' is NaN")  # another problem: logged
    now[0] += 4.9
    warn("joint 'a' is NaN")
    now[0] += 0.2  # 5.1 s after the first
    warn("joint 'a' is NaN")
    assert logger.lines == [
        ("warning", "joint 'a' is NaN (repeats are not logged for 5 s)"),
        ("warning", "joint 'b' is NaN (repeats are not logged for 5 s)"),
        ("warning", "joint 'a' is NaN (repeats are not logged for 5 s)"),
    ]


def test_problems_of_one_kind_share_their_period():
    logger, now = Recorder(), [0.0]
    warn = ThrottledWarnings(logger, period_s=1.0, clock=lambda: now[0])
    warn("an IK answer left 30 ms late", kind="late IK answer")
    warn("an IK answer left 45 ms late", kind="late IK answer")
    now[0] = 1.0
    warn("an IK answer left 25 ms late", kind="late IK answer")
    assert [text for _, text in logger.lines] == [
        "an IK answer left 30 ms late (repeats are not logged for 1 s)",
        "an IK answer left 25 ms late (repeats are not logged for 1 s)",
    ]


def test_memory_stays_bounded_by_forgetting_all_kinds_at_once():
    logger = Recorder()
    warn = ThrottledWarnings(logger, period_s=60.0, clock=lambda: 0.0, kinds=3)
    for k in range(3):
        warn(f"problem {k}")
    warn("problem 0")  # remembered: not logged
    warn("problem 3")  # a fourth key: the three are forgotten, this one logged
    warn("problem 0")  # forgotten, so logged again
    assert [text.split(" (")[0] for _, text in logger.lines] == [
        "problem 0",
        "problem 1",
        "problem 2",
        "problem 3",
        "problem 0",
    ]
