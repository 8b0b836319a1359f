"""Bad inputs of `har` and `scene` (issue 9; review cases A8, B2, B3, B8, B11, B13-B17,
C15-C21): one error line naming the option or the file, exit 2, no traceback; outputs checked
before the work (no folder created), never over an input."""

from __future__ import annotations

import json

import numpy as np
import pytest

from flexhrc.cli import main


@pytest.fixture(scope="module")
def model(tmp_path_factory, toy_model):
    path = tmp_path_factory.mktemp("model") / "toy.npz"
    toy_model.save(path)
    return path


@pytest.fixture(scope="module")
def trial(tmp_path_factory, toy_trials):
    path = tmp_path_factory.mktemp("trial") / "walk-1-m1.npy"
    np.save(path, toy_trials[0].samples)
    return path


def _error(capsys) -> str:
    err = capsys.readouterr().err
    assert "Traceback" not in err
    lines = [line for line in err.splitlines() if line.startswith("error:")]
    assert len(lines) == 1, err
    return lines[0]


CASES = [  # (argv with {model} {trial} {toy} {tmp}, expected part of the error line)
    # numeric options: NaN, inf, negative, absurdly large -> the option is named (B11-B15, C16-C18)
    (["har", "synth", "{model}", "pick_up", "-o", "{tmp}/s.csv", "--seed", "-1"], "--seed"),
    (["har", "train", "{toy}", "-o", "{tmp}/m.npz", "--seed", "-5"], "argument --seed"),
    (["har", "synth", "{model}", "pick_up", "-o", "{tmp}/s.csv", "--gap", "-5"], "argument --gap"),
    (["har", "synth", "{model}", "pick_up", "-o", "{tmp}/s.csv", "--gap", "nan"], "--gap"),
    (["har", "synth", "{model}", "pick_up", "-o", "{tmp}/s.csv", "--gap", "inf"], "--gap"),
    (["har", "synth", "{model}", "pick_up", "-o", "{tmp}/s.csv", "--gap", "1e7"], "--gap"),
    (["har", "eval", "--cv", "volunteer", "{toy}", "--folds", "0"], "argument --folds"),
    (["har", "eval", "--cv", "volunteer", "{toy}", "--folds", "1"], "argument --folds"),
    (["har", "eval", "--cv", "volunteer", "{toy}", "--folds", "-2"], "argument --folds"),
    (["har", "eval", "--cv", "volunteer", "{toy}", "--folds", "9"], "--folds 9: the data have 3"),
    (["har", "stream", "{model}", "{trial}", "--stride", "0"], "argument --stride"),
    (["har", "stream", "{model}", "{trial}", "--stride", "-5"], "argument --stride"),
    (["har", "stream", "{model}", "{trial}", "--speed", "-1"], "argument --speed"),
    (["har", "stream", "{model}", "{trial}", "--speed", "nan"], "argument --speed"),
    (["har", "stream", "{model}", "{trial}", "--speed", "1e-9"], "--speed 1e-09: give 0"),
    (["har", "train", "{toy}", "-o", "{tmp}/m.npz", "--max-components", "100000"], "--max-comp"),
    (["har", "train", "{toy}", "-o", "{tmp}/m.npz", "--min-trials", "-1"], "--min-trials"),
    # companion flags (C20)
    (["har", "eval", "{model}", "{toy}", "--folds", "3"], "--folds goes with --cv volunteer"),
    (["har", "eval", "{model}", "{toy}", "--baseline"], "--baseline goes with --cv volunteer"),
    # outputs checked before the work (A8, B8)
    (["har", "train", "{toy}", "-o", "{tmp}/none/m.npz"], "-o {tmp}/none/m.npz: folder"),
    (["har", "train", "{toy}", "-o", "{tmp}"], "unsupported output format '(none)'"),
    (["har", "train", "{toy}", "-o", "/dev/full"], "-o /dev/full: unsupported output format"),
    (["har", "train", "{toy}", "-o", "{tmp}/m.txt"], "unsupported output format '.txt'"),
    (["har", "synth", "{model}", "pick_up", "-o", "{tmp}/none/s.csv"], "folder"),
    (["har", "synth", "{model}", "pick_up", "-o", "{model}"], "unsupported output format"),
    (["scene", "generate", "-o", "{tmp}/none/c.npy"], "-o {tmp}/none/c.npy: folder"),
    (["scene", "generate", "-o", "{tmp}/c.png"], "unsupported output format '.png'"),
    # scene numbers (B17, C21)
    (["scene", "bench", "--scenes", "1", "--noise", "nan"], "argument --noise"),
    (["scene", "bench", "--scenes", "1", "--noise", "inf"], "argument --noise"),
    (["scene", "bench", "--scenes", "1", "--dropout", "2"], "argument --dropout"),
    (["scene", "bench", "--scenes", "1", "--dropout", "1"], "argument --dropout"),
    (["scene", "bench", "--scenes", "1", "--width", "0"], "argument --width"),
    (["scene", "bench", "--seed", "-3"], "argument --seed"),
    (["scene", "detect", "{tmp}/depth.npy", "--intrinsics", "0,0,0,0"], "fx, fy must be > 0"),
    (["scene", "detect", "{tmp}/depth.npy", "--intrinsics", "nan,1,1,1"], "must be finite"),
    (["scene", "detect", "{tmp}/nan.npy"], "no finite value"),
    (["scene", "detect", "{tmp}/cloud.npy", "--rules", "{tmp}/b.yaml"], "b.yaml: not a text"),
    (["scene", "detect", "{tmp}/cloud.npy", "--rules", "{tmp}"], "is a folder"),
    # inputs: empty model (B16), NaN recording (C15), too short a trial (C19)
    (["har", "eval", "{tmp}/empty.npz", "{toy}"], "empty.npz: not a flexhrc HAR model"),
    (["har", "stream", "{model}", "{tmp}/nan.npy"], "nan.npy: non-finite acceleration"),
    (["har", "train", "{tmp}/short", "-o", "{tmp}/m.npz"], "too short: 1 sample(s)"),
]


@pytest.mark.parametrize(("argv", "expected"), CASES)
def test_bad_har_and_scene_inputs(argv, expected, capsys, tmp_path, toy_dir, model, trial):
    np.save(tmp_path / "depth.npy", np.ones((20, 30)))
    np.save(tmp_path / "nan.npy", np.full((500, 3), np.nan))
    np.save(tmp_path / "cloud.npy", np.zeros((200, 3)))
    (tmp_path / "b.yaml").write_bytes(bytes(range(256)) * 4)
    (tmp_path / "empty.npz").write_bytes(b"")
    (tmp_path / "short" / "walk").mkdir(parents=True)
    np.save(tmp_path / "short" / "walk" / "w-1-m1.npy", np.zeros((1, 3)))
    subs = {"{model}": str(model), "{trial}": str(trial), "{toy}": str(toy_dir)}
    subs["{tmp}"] = str(tmp_path)
    args = []
    for a in argv:
        for k, v in subs.items():
            a = a.replace(k, v)
        args.append(a)
    for k, v in subs.items():
        expected = expected.replace(k, v)
    before = sorted(p.name for p in tmp_path.iterdir())
    assert main(args) == 2
    assert expected in _error(capsys)
    assert sorted(p.name for p in tmp_path.iterdir()) == before  # nothing written or created


def test_har_training_warns_about_what_it_drops(tmp_path, toy_dir, capsys):  # C19
    import shutil

    data = tmp_path / "data"
    shutil.copytree(toy_dir, data)
    (data / "nothing").mkdir()
    actions = sorted(p for p in data.iterdir() if p.is_dir() and any(p.iterdir()))
    lone = actions[0]
    for extra in sorted(lone.iterdir())[1:]:
        extra.unlink()
    out = tmp_path / "m.npz"
    assert main(["har", "train", str(data), "-o", str(out), "--max-components", "2"]) == 0
    err = capsys.readouterr().err
    assert f"warning: {data / 'nothing'}: no trial files" in err
    assert f"warning: {lone}: a single trial" in err
    assert "training on" in err  # progress goes to stderr
    assert main(["har", "train", str(data), "-o", str(out), "--min-trials", "2"]) == 0
    err = capsys.readouterr().err
    assert f"warning: {lone}: 1 trial(s), fewer than the 2 asked for" in err


def test_unreadable_training_data(tmp_path, toy_dir):  # B2
    import shutil

    from ..taskmanager.test_cli_hardening import unprivileged

    data = tmp_path / "data"
    shutil.copytree(toy_dir, data)
    victim = sorted(next(p for p in sorted(data.iterdir()) if p.is_dir()).iterdir())[0]
    victim.chmod(0)
    proc = unprivileged(["har", "train", str(data), "-o", str(tmp_path / "m.npz")])
    assert proc.returncode == 2 and "Traceback" not in proc.stderr
    assert proc.stderr.strip() == f"error: {victim}: cannot read: permission denied"
    assert not (tmp_path / "m.npz").exists()


def test_har_model_written_atomically_and_confusion_matrix_labelled(tmp_path, toy_dir, capsys):
    out = tmp_path / "m.npz"
    assert main(["har", "train", str(toy_dir), "-o", str(out), "--max-components", "2"]) == 0
    capsys.readouterr()
    assert out.is_file() and [p.name for p in tmp_path.iterdir()] == ["m.npz"]  # no temp left
    assert main(["har", "eval", str(out), str(toy_dir)]) == 0
    text = capsys.readouterr().out
    assert "rows: true action, columns: predicted action" in text
    head = next(line for line in text.splitlines() if "true \\ predicted" in line)
    assert "[1]" in head and "[2]" in head
    assert any(line.strip().startswith("[1] ") for line in text.splitlines())


def test_scene_detect_counts_in_words(tmp_path, capsys):
    cloud = tmp_path / "c.npy"
    assert main(["scene", "generate", "-o", str(cloud), "--json"]) == 0
    truth = len(json.loads(capsys.readouterr().out)["objects"])
    assert main(["scene", "detect", str(cloud)]) == 0
    first = capsys.readouterr().out.splitlines()[0]
    assert first in (f"{truth} objects", f"{truth - 1} objects", f"{truth + 1} objects")
