from flexhrc.behavior import ArmMutex, MutexRequest, NetworkParams
from flexhrc.behavior.messages import MutexRelease, release_topic, reply_topic, request_topic
from flexhrc.transport import InProcessBus


class MutexHarness:
    def __init__(self, window=0.3):
        self.bus = InProcessBus()
        self.mutex = ArmMutex("left", self.bus, NetworkParams(mutex_window=window, tick_period=0.1))
        self.replies: list[tuple[str, bool]] = []
        for n in "abc":
            self.bus.subscribe(reply_topic(n), lambda m, n=n: self.replies.append((n, m.granted)))
        self.tick_no = 0

    def step(self, bids=None, release=None):
        for name, pot in (bids or {}).items():
            self.bus.publish(request_topic("left"), MutexRequest(name, pot))
        if release:
            self.bus.publish(release_topic("left"), MutexRelease(release))
        self.bus.flush()
        self.replies.clear()
        self.mutex.update(self.tick_no, self.tick_no * 0.1)
        self.tick_no += 1
        self.bus.flush()
        return list(self.replies)


def test_window_then_highest_bid_wins_and_losers_are_denied():
    h = MutexHarness(window=0.3)
    assert h.mutex.window_ticks == 3
    assert h.step({"a": 1.0}) == []  # first request opens the window
    assert h.step({"a": 1.0, "b": 2.0}) == []  # b bids during the window
    assert h.step({"a": 1.0, "b": 2.0}) == []
    replies = h.step({"a": 1.0, "b": 2.0, "c": 0.5})
    assert ("b", True) in replies and ("a", False) in replies and ("c", False) in replies
    assert h.mutex.holder == "b"


def test_locked_mutex_ignores_requests_until_released():
    h = MutexHarness(window=0.1)
    h.step({"a": 1.0})
    assert h.step({"a": 1.0}) == [("a", True)]
    assert h.step({"b": 5.0}) == []
    assert h.step({"b": 5.0}, release="c") == []  # only the holder can release
    assert h.mutex.holder == "a"
    assert h.step({"b": 5.0}, release="a") == []  # released; b's request opens a new window
    assert h.mutex.holder is None
    assert h.step({"b": 5.0}) == [("b", True)]


def test_bidders_that_stop_bidding_drop_out_and_ties_go_to_smallest_name():
    h = MutexHarness(window=0.2)
    h.step({"a": 9.0, "b": 1.0})
    h.step({"a": 9.0, "b": 1.0})
    assert h.step({"b": 1.0, "c": 1.0}) == [("b", True), ("c", False)]  # a left; b, c tie


def test_window_closing_with_no_fresh_bid_grants_nothing():
    h = MutexHarness(window=0.1)
    h.step({"a": 1.0})
    assert h.step({}) == []
    assert h.mutex.holder is None
    h.step({"a": 1.0})
    assert h.step({"a": 1.0}) == [("a", True)]
