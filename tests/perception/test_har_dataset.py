from pathlib import Path

import numpy as np
import pytest

from flexhrc.errors import FlexhrcError, FormatError, UnknownNameError
from flexhrc.perception.human.dataset import (
    HMP_SEVEN,
    Trial,
    decode_hmp,
    load_dataset,
    read_trial_file,
    save_csv,
    summarise,
    volunteer_of,
)


def test_decode_hmp_range():
    assert decode_hmp(np.array([0, 63])).tolist() == [-1.5, 1.5]
    assert decode_hmp(np.array([31.5]))[0] == pytest.approx(0.0)


def test_read_hmp_txt(tmp_path: Path):
    f = tmp_path / "Accelerometer-2011-03-24-10-24-39-climb_stairs-f1.txt"
    f.write_text("0 63 21\n21 21 42\n")
    x = read_trial_file(f)
    assert x.shape == (2, 3)
    assert x[0, 0] == -1.5 and x[0, 1] == 1.5
    assert volunteer_of(f) == "f1"


@pytest.mark.parametrize(
    ("content", "line", "needle"),
    [("1 2 3\n1 2\n", 2, "expected 3"), ("1 2 3\n1 x 3\n", 2, "not an integer"),
     ("64 0 0\n", 1, "0..63")],
)  # fmt: skip
def test_read_hmp_txt_errors_name_file_and_line(tmp_path, content, line, needle):
    f = tmp_path / "bad.txt"
    f.write_text(content)
    with pytest.raises(FormatError) as err:
        read_trial_file(f)
    assert f"bad.txt:{line}:" in str(err.value) and needle in str(err.value)


def test_csv_and_npy_roundtrip(tmp_path):
    x = np.random.default_rng(0).normal(size=(20, 3))
    save_csv(tmp_path / "a-01-m2.csv", x)
    np.save(tmp_path / "b.npy", x)
    assert np.allclose(read_trial_file(tmp_path / "a-01-m2.csv"), x, atol=1e-6)
    assert np.allclose(read_trial_file(tmp_path / "b.npy"), x)
    assert volunteer_of(tmp_path / "a-01-m2.csv") == "m2"
    # A headerless three-column CSV works too.
    (tmp_path / "c.csv").write_text("0.1,0.2,0.3\n0.4,0.5,0.6\n")
    assert read_trial_file(tmp_path / "c.csv").shape == (2, 3)


def test_malformed_csv_names_file_and_line(tmp_path):
    f = tmp_path / "t.csv"
    f.write_text("t,ax,ay,az\n0,0.1,0.2,0.3\n0.03,0.1,oops,0.3\n")
    with pytest.raises(FormatError, match=r"t\.csv:3: not a number"):
        read_trial_file(f)
    g = tmp_path / "u.csv"
    g.write_text("0.1,0.2\n")
    with pytest.raises(FormatError, match=r"u\.csv:1: expected 3"):
        read_trial_file(g)


def test_bad_files(tmp_path):
    with pytest.raises(FlexhrcError, match="no such file"):
        read_trial_file(tmp_path / "missing.csv")
    (tmp_path / "x.json").write_text("{}")
    with pytest.raises(FormatError, match="unknown trial format"):
        read_trial_file(tmp_path / "x.json")
    np.save(tmp_path / "bad.npy", np.zeros((4, 2)))
    with pytest.raises(FormatError, match=r"\(n, 3\)"):
        read_trial_file(tmp_path / "bad.npy")
    (tmp_path / "empty.csv").write_text("t,ax,ay,az\n")
    with pytest.raises(FormatError, match="no samples"):
        read_trial_file(tmp_path / "empty.csv")


def test_load_dataset_layout_and_errors(tmp_path, toy_dir):
    trials = load_dataset(toy_dir)
    assert set(summarise(trials)) == {"pick_up", "put_down", "screw", "wave"}
    assert {t.volunteer for t in trials} == {"v1", "v2", "v3"}
    only = load_dataset(toy_dir, actions=["Screw"])
    assert {t.action for t in only} == {"screw"}
    with pytest.raises(UnknownNameError, match="no action folder for jump"):
        load_dataset(toy_dir, actions=["jump"])
    (tmp_path / "empty").mkdir()
    with pytest.raises(FlexhrcError, match="no trials found"):
        load_dataset(tmp_path / "empty")
    with pytest.raises(FlexhrcError, match="not a directory"):
        load_dataset(tmp_path / "nope")
    with pytest.raises(FlexhrcError, match="no trials"):
        load_dataset(toy_dir, min_trials=100)


def test_trial_validates_shape():
    with pytest.raises(FormatError):
        Trial("a", np.zeros((3, 2)))


@pytest.mark.shared
def test_hmp_layout(hmp_dir):
    trials = load_dataset(hmp_dir, actions=HMP_SEVEN)
    counts = summarise(trials)
    assert set(counts) == set(HMP_SEVEN)
    assert all(n >= 20 for n in counts.values())
    assert set(summarise(load_dataset(hmp_dir, min_trials=20))) >= set(HMP_SEVEN)
    assert all(t.volunteer[0] in "mf" for t in trials)
    assert all(t.samples.min() >= -1.5 and t.samples.max() <= 1.5 for t in trials)
