"""``flexhrc.perception.human.api`` and ``flexhrc.perception.scene.api``: each report equals
what the ``flexhrc har`` / ``flexhrc scene`` command prints with ``--json`` for the same
arguments (less the wall-clock timings)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from flexhrc.cli import main
from flexhrc.errors import FlexhrcError
from flexhrc.perception.human import api as har
from flexhrc.perception.scene import api as scene

TIMINGS = ("seconds", "processing_s", "speed_x_realtime")


def _json(capsys, *argv: str):
    assert main([*argv, "--json"]) == 0
    return json.loads(capsys.readouterr().out)


def _untimed(report: dict) -> dict:
    return {k: v for k, v in report.items() if k not in TIMINGS}


@pytest.fixture(scope="module")
def model(tmp_path_factory, toy_dir):
    path = tmp_path_factory.mktemp("api") / "toy.npz"
    lines: list[str] = []
    report = har.train(toy_dir, path, max_components=2, progress=lines.append)
    assert path.is_file() and report["model"] == str(path)
    assert set(report["actions"]) >= {"screw", "pick_up"} and lines[0].startswith("training on")
    return path


def test_train_equals_har_train(capsys, tmp_path, toy_dir, model):
    cli = _json(capsys, "har", "train", str(toy_dir), "-o", str(tmp_path / "cli.npz"),
                "--max-components", "2")  # fmt: skip
    report = har.train(toy_dir, tmp_path / "lib.npz", max_components=2)
    assert _untimed(report) | {"model": ""} == _untimed(cli) | {"model": ""}


def test_evaluate_and_cross_validation_equal_har_eval(capsys, toy_dir, model):
    assert har.evaluate(model, toy_dir) == _json(capsys, "har", "eval", str(model), str(toy_dir))
    folds: list[str] = []
    report = har.cross_validation(toy_dir, folds=2, baseline=True, actions=["screw", "wave"],
                                  progress=folds.append)  # fmt: skip
    assert report == _json(capsys, "har", "eval", "--cv", "volunteer", str(toy_dir), "--folds",
                           "2", "--baseline", "--actions", "screw,wave")  # fmt: skip
    assert report["split"] == "2 folds by volunteer" and set(report) == {
        "split", "gmm_gmr", "baseline_rf"}  # fmt: skip
    assert any(line.startswith("[baseline_rf]") for line in folds)
    with pytest.raises(FlexhrcError, match="--folds 9: the data have 3 volunteers"):
        har.cross_validation(toy_dir, folds=9)


def test_synthesise_then_stream_equal_the_commands(capsys, tmp_path, model):
    rec = tmp_path / "lib.csv"
    report = har.synthesise(model, ["pick_up", "screw"], rec, seed=4)
    cli = _json(capsys, "har", "synth", str(model), "pick_up,screw", "-o", str(tmp_path / "c.csv"),
                "--seed", "4")  # fmt: skip
    assert report | {"file": ""} == cli | {"file": ""}
    heard: list[tuple[str, bool]] = []
    streamed = har.stream(model, rec, on_recognition=lambda r, end: heard.append((r.name, end)))
    assert [name for name, _ in heard] == [r["name"] for r in streamed["recognised"]]
    assert [r["name"] for r in streamed["recognised"]] == ["pick_up", "screw"]
    assert _untimed(streamed) == _untimed(_json(capsys, "har", "stream", str(model), str(rec)))


def test_scene_generate_and_detect_equal_the_commands(capsys, tmp_path):
    report = scene.generate(tmp_path / "lib.npy", seed=2, depth=True)
    cli = _json(capsys, "scene", "generate", "-o", str(tmp_path / "cli.npy"), "--seed", "2",
                "--depth")  # fmt: skip
    assert report | {"file": ""} == cli | {"file": ""}
    assert np.load(tmp_path / "lib.npy").shape == tuple(report["shape"])
    intrinsics = tuple(report["intrinsics"])
    found, objects = scene.detect(tmp_path / "lib.npy", intrinsics=intrinsics)
    assert found["objects"] == [o.to_dict() for o in objects] and objects
    assert found == _json(capsys, "scene", "detect", str(tmp_path / "lib.npy"), "--intrinsics",
                          ",".join(str(v) for v in intrinsics))  # fmt: skip
    with pytest.raises(FlexhrcError, match="a depth image needs"):
        scene.detect(tmp_path / "lib.npy")
