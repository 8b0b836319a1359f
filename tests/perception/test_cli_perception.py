import json

import numpy as np
import pytest

from flexhrc.cli import main


def run(capsys, *argv):
    code = main(list(argv))
    out = capsys.readouterr()
    return code, out.out, out.err


@pytest.fixture(scope="module")
def trained(tmp_path_factory, toy_dir):
    model = tmp_path_factory.mktemp("m") / "toy.npz"
    assert main(["har", "train", str(toy_dir), "-o", str(model), "--max-components", "2"]) == 0
    return model


def test_har_train_eval_json(capsys, trained, toy_dir):
    code, out, _ = run(capsys, "har", "eval", str(trained), str(toy_dir), "--json")
    assert code == 0
    rep = json.loads(out)
    assert rep["accuracy"] >= 0.9
    assert set(rep) >= {"accuracy", "macro_f1", "per_class", "confusion_matrix"}
    assert set(rep["per_class"]["screw"]) >= {"precision", "recall"}


def test_har_train_text_and_actions(capsys, tmp_path, toy_dir):
    code, out, _ = run(capsys, "har", "train", str(toy_dir), "-o", str(tmp_path / "m.npz"),
                       "--actions", "screw,wave", "--max-components", "2")  # fmt: skip
    assert code == 0 and "saved" in out and "screw" in out and "pick_up" not in out


def test_har_eval_cv_volunteer(capsys, toy_dir):
    code, out, err = run(capsys, "har", "eval", "--cv", "volunteer", str(toy_dir), "--baseline",
                         "--actions", "screw,wave,pick_up", "--json")  # fmt: skip
    assert code == 0
    rep = json.loads(out)  # stdout is pure JSON, progress went to stderr
    assert rep["split"] == "leave-one-volunteer-out"
    assert rep["gmm_gmr"]["accuracy"] >= 0.9 and "baseline_rf" in rep
    assert "fold v1" in err


def test_har_synth_then_stream(capsys, tmp_path, trained):
    rec = tmp_path / "rec.csv"
    code, out, _ = run(capsys, "har", "synth", str(trained), "pick_up,screw", "-o", str(rec))
    assert code == 0 and rec.is_file()
    code, out, _ = run(capsys, "har", "stream", str(trained), str(rec), "--json")
    data = json.loads(out)
    assert [r["name"] for r in data["recognised"]] == ["pick_up", "screw"]
    assert data["speed_x_realtime"] > 1
    code, out, _ = run(capsys, "har", "stream", str(trained), str(rec))
    assert "pick_up" in out and "2 recognitions in" in out


@pytest.mark.parametrize(
    ("argv", "needle"),
    [(["har", "train", "{empty}", "-o", "{tmp}/m.npz"], "no trials found"),
     (["har", "train", "{toy}", "-o", "{tmp}/m.npz", "--actions", "jump"], "jump"),
     (["har", "eval", "{tmp}/none.npz", "{toy}"], "no such model"),
     (["har", "eval", "--cv", "volunteer", "{toy}", "{toy}"], "one argument"),
     (["har", "stream", "{model}", "{tmp}/bad.csv"], "bad.csv:2:"),
     (["har", "synth", "{model}", "jump", "-o", "{tmp}/x.csv"], "unknown action 'jump'"),
     (["scene", "detect", "{tmp}/none.npy"], "no such file"),
     (["scene", "bench", "--scenes", "0"], "--scenes")],
)  # fmt: skip
def test_user_errors_are_one_line_exit_2(capsys, tmp_path, toy_dir, trained, argv, needle):
    (tmp_path / "empty").mkdir()
    (tmp_path / "bad.csv").write_text("ax,ay,az\n0,0,zz\n")
    subs = {"{empty}": str(tmp_path / "empty"), "{tmp}": str(tmp_path), "{toy}": str(toy_dir),
            "{model}": str(trained)}  # fmt: skip
    args = []
    for a in argv:
        for k, v in subs.items():
            a = a.replace(k, v)
        args.append(a)
    code, _, err = run(capsys, *args)
    assert code == 2
    assert err.startswith("error: ") and needle in err and "Traceback" not in err


def test_scene_bench_json(capsys):
    code, out, _ = run(capsys, "scene", "bench", "--scenes", "2", "--seed", "1", "--noise",
                       "0.002", "--width", "200", "--height", "150", "--json")  # fmt: skip
    assert code == 0
    res = json.loads(out)
    for key in ("detection_rate", "position_error_m", "size_error_rel", "type_accuracy", "frame_s"):
        assert key in res


def test_scene_generate_and_detect(capsys, tmp_path):
    cloud = tmp_path / "c.npy"
    assert main(["scene", "generate", "-o", str(cloud), "--seed", "2"]) == 0
    capsys.readouterr()
    code, out, _ = run(capsys, "scene", "detect", str(cloud), "--json")
    assert code == 0 and len(json.loads(out)["objects"]) >= 5
    depth = tmp_path / "d.npy"
    assert main(["scene", "generate", "-o", str(depth), "--seed", "2", "--depth", "--json"]) == 0
    gen = json.loads(capsys.readouterr().out)
    intr = ",".join(str(v) for v in gen["intrinsics"])
    code, out, _ = run(capsys, "scene", "detect", str(depth), "--intrinsics", intr, "--json")
    assert code == 0 and len(json.loads(out)["objects"]) == len(gen["objects"])
    code, _, err = run(capsys, "scene", "detect", str(depth))
    assert code == 2 and "--intrinsics" in err
    np.save(tmp_path / "bad.npy", np.zeros((2, 2, 2)))
    code, _, err = run(capsys, "scene", "detect", str(tmp_path / "bad.npy"))
    assert code == 2 and "bad.npy" in err


def test_perception_import_stays_light():
    import os
    import subprocess
    import sys
    from pathlib import Path

    src = str(Path(__file__).resolve().parents[2] / "src")
    env = {**os.environ, "PYTHONPATH": src + os.pathsep + os.environ.get("PYTHONPATH", "")}

    code = (
        "import sys, flexhrc.perception.human, flexhrc.perception.scene, flexhrc.cli.har, "
        "flexhrc.cli.scene; print([m for m in ('sklearn', 'scipy') if m in sys.modules])"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, env=env
    )
    assert out.stdout.strip() == "[]"
