import numpy as np
import pytest

from flexhrc.errors import FormatError, UnknownNameError
from flexhrc.perception.human import (
    ActionMapping,
    HumanActionPublisher,
    OnlineRecognizer,
    RecognisedAction,
    SimulatedWearable,
)


def test_wearable_is_deterministic_and_checks_names(toy_model):
    a = SimulatedWearable(toy_model, seed=4).stream("screw")
    b = SimulatedWearable(toy_model, seed=4).stream("screw")
    c = SimulatedWearable(toy_model, seed=5).stream("screw")
    assert a.shape[1] == 3 and np.array_equal(a, b) and not np.array_equal(a, c)
    with pytest.raises(UnknownNameError, match="model knows"):
        SimulatedWearable(toy_model).stream("jump")
    with pytest.raises(ValueError):
        SimulatedWearable(toy_model, deviation=-1)


@pytest.mark.parametrize("seed", [0, 1])
def test_synthesised_streams_are_recognised_as_their_action(toy_model, seed):
    w = SimulatedWearable(toy_model, seed=seed)
    streams = [w.stream(a) for a in toy_model.classes_]
    assert toy_model.predict(streams) == toy_model.classes_
    d = toy_model.distances(streams) / toy_model.thresholds()
    assert np.all(np.diag(d) < 1.5)  # near or below threshold (online, several window scales)


def test_online_replay_reports_each_action_once_and_in_time(toy_model):
    w = SimulatedWearable(toy_model, seed=2)
    order = ["pick_up", "screw", "put_down", "wave"]
    x, truth = w.sequence(order, gap_s=2.0)
    found = OnlineRecognizer(toy_model).replay(x)
    assert [r.name for r in found] == order
    for r, (name, start, end) in zip(found, truth, strict=True):
        window = toy_model.model(name).length / 32.0
        assert start < r.t_end <= end + window  # at the latest one window after the end
        assert 0 < r.confidence <= 1
        assert r.t_start < r.t_end


def test_online_is_chunking_invariant(toy_model):
    x, _ = SimulatedWearable(toy_model, seed=3).sequence(["wave", "screw"])
    a = OnlineRecognizer(toy_model).replay(x, chunk=5)
    b = OnlineRecognizer(toy_model).replay(x, chunk=64)
    assert a == b


def test_online_silence_reports_nothing(toy_model):
    still = np.tile([0.0, 1.0, 0.0], (400, 1))
    assert OnlineRecognizer(toy_model).replay(still) == []


def test_online_validation(toy_model):
    with pytest.raises(ValueError):
        OnlineRecognizer(toy_model, stride=0)
    with pytest.raises(ValueError):
        OnlineRecognizer(toy_model, scales=())


def test_mapping_from_data_and_yaml(tmp_path, toy_model):
    m = ActionMapping.from_dict({"mapping": {"pick_up": "pick_up_leg"}, "min_confidence": 0.3})
    assert m.map(RecognisedAction("pick_up", 0, 1, 0.5)) == "pick_up_leg"
    assert m.map(RecognisedAction("pick_up", 0, 1, 0.1)) is None  # too weak
    assert m.map("wave") is None  # unmapped: dropped
    f = tmp_path / "map.yaml"
    f.write_text("mapping:\n  screw: screw\n  put_down: put_down\n")
    assert ActionMapping.load(f).mapping == {"screw": "screw", "put_down": "put_down"}
    f.write_text("mapping: [\n")
    with pytest.raises(FormatError, match=r"map\.yaml"):
        ActionMapping.load(f)
    with pytest.raises(FormatError, match="non-empty name"):
        ActionMapping.from_dict({"screw": 3})
    with pytest.raises(UnknownNameError, match="jump"):
        ActionMapping({"jump": "x"}).check(toy_model.classes_)
    assert ActionMapping.identity(["a"]).map("a") == "a"


def test_publisher_drives_a_callback_from_a_signal(toy_model):
    """The round-2 bridge in miniature: wearable -> recogniser -> mapping -> callback."""
    received: list[tuple[str, float]] = []
    mapping = ActionMapping({"pick_up": "pick_up", "screw": "screw", "put_down": "put_down"})
    pub = HumanActionPublisher(
        OnlineRecognizer(toy_model), mapping, lambda name, r: received.append((name, r.t_end))
    )
    x, _ = SimulatedWearable(toy_model, seed=0).sequence(["pick_up", "wave", "screw"])
    for i in range(0, len(x), 16):
        pub.push(x[i : i + 16])
    pub.finish()
    assert [n for n, _ in received] == ["pick_up", "screw"]  # wave is not mapped
