"""``flexhrc sim``: JSON keys, exit codes, errors naming the argument, headless view."""

from __future__ import annotations

import json

import numpy as np
import pytest

from flexhrc.cli import main


def _run(capsys, *argv):
    code = main(["sim", *argv])
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def test_sim_json_has_the_promised_keys(capsys):
    code, out, _ = _run(capsys, "transport", "--arm", "left", "--target", "0.5", "0.1", "0.2",
                        "--json")  # fmt: skip
    assert code == 0
    data = json.loads(out)
    for key in ("success", "reason", "duration_s", "wall_s", "final_error_m"):
        assert key in data
    assert data["success"] is True and data["final_error_m"] < 1e-3
    assert 0 < data["duration_s"] < 10 and data["wall_s"] > 0


def test_sim_failure_exits_1_with_reason(capsys):
    code, out, _ = _run(capsys, "transport", "--target", "1.5", "0.1", "0.2", "--json")
    data = json.loads(out)
    assert code == 1 and data["success"] is False and "out of reach" in data["reason"]
    assert data["final_error_m"] is None  # JSON has no infinity


def test_sim_with_obstacle_after_and_trajectory(capsys):
    code, out, _ = _run(
        capsys, "transport", "--arm", "right", "--target", "0.5", "-0.1", "0.1",
        "--after", "approach", "--obstacle", "0.5", "-0.1", "0.3", "0.03", "--trajectory",
        "--json",
    )  # fmt: skip
    data = json.loads(out)
    assert code == 0 and data["after"][0]["action"] == "approach"
    assert data["obstacles"][0]["type"] == "sphere"
    assert len(data["trajectory"]["t"]) == data["steps"] + 1


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["transport", "--target", "0.5", "0.1"], "--target must be 3 numbers"),
        (["transport", "--target", "0.5", "a", "0.2"], "--target must be numbers"),
        (["transport", "--arm", "middle", "--target", "0.5", "0.1", "0.2"], "argument 'arm'"),
        (["juggle", "--target", "0.5", "0.1", "0.2"], "argument 'action'"),
        (["transport", "--target", "0.5", "0.1", "0.2", "--obstacle", "1", "2"], "--obstacle 1"),
        (["transport"], "needs a target"),
        (
            ["transport", "--target", "0.5", "0.1", "0.2", "--view", "x.txt"],
            "unsupported output format '.txt'; use one of .gif, .png",
        ),
    ],
)
def test_sim_bad_input_is_one_line_exit_2(capsys, argv, message):
    code, out, err = _run(capsys, *argv)
    assert code == 2 and out == ""
    assert err.startswith("error: ") and message in err and "Traceback" not in err


def test_sim_view_writes_a_png(capsys, tmp_path):
    pytest.importorskip("pybullet")
    png = tmp_path / "view.png"
    code, out, _ = _run(capsys, "transport", "--target", "0.5", "0.1", "0.2", "--view", str(png))
    assert code == 0 and png.stat().st_size > 1000
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert "view:" in out


@pytest.mark.parametrize(
    ("argv", "message"),
    [  # review B12, C22, C5
        (["--dt", "nan"], "--dt must be in (0, 0.1] seconds, got nan"),
        (["--dt", "1e-9"], "--dt must be at least 0.001 s"),
        (["--time-budget", "inf"], "--time-budget must be positive and at most 600 s"),
        (["--time-budget", "nan"], "--time-budget must be positive"),
        (["--time-budget", "500", "--dt", "0.001"], "500000 steps; at most"),
        (["--yaw", "nan"], "argument --yaw"),
        (["--from", "0.4", "0.1", "0.2"], "--from goes with --after"),
        (["--trajectory"], "--trajectory goes with --json"),
        (["--view", "{tmp}/nonexistent/out.png"], "folder {tmp}/nonexistent does not exist"),
    ],
)
def test_sim_numbers_companions_and_view_path(argv, message, capsys, tmp_path):
    argv = [a.replace("{tmp}", str(tmp_path)) for a in argv]
    code, _, err = _run(capsys, "transport", "--target", "0.5", "0.1", "0.2", *argv)
    assert code == 2 and "Traceback" not in err
    assert message.replace("{tmp}", str(tmp_path)) in err
    assert not (tmp_path / "nonexistent").exists()  # no folder created


def test_sim_view_has_legend_labels_and_keeps_stdout_json(capsys, tmp_path):
    pytest.importorskip("pybullet")
    from PIL import Image

    out = tmp_path / "v.png"
    code, stdout, _ = _run(capsys, "approach", "--arm", "right", "--target", "0.5", "-0.1", "0.05",
                           "--obstacle", "0.5", "-0.1", "0.2", "0.04", "--view", str(out),
                           "--json")  # fmt: skip
    assert code == 1  # blocked by the obstacle
    assert json.loads(stdout)["view"] == str(out)  # stdout is pure JSON
    img = np.asarray(Image.open(out).convert("RGB")).astype(int)
    # the legend's swatch of the obstacle colour (top-left), drawn in the picture itself
    red = (abs(img[..., 0] - 216) < 3) & (abs(img[..., 1] - 38) < 3) & (abs(img[..., 2] - 25) < 3)
    assert red[:120, :30].sum() >= 50
    # text (dark pixels) in the legend area and near the projected obstacle
    assert (img[:120, 20:200].sum(axis=2) < 100).sum() > 100
    assert [p.name for p in tmp_path.iterdir()] == ["v.png"]  # written atomically, no temp left


def test_view_labels_are_placed_where_the_objects_are():
    p = pytest.importorskip("pybullet")
    from flexhrc.action.view import _project

    # a camera at +x looking at the origin: the origin projects to the image centre
    view = p.computeViewMatrix([2, 0, 0], [0, 0, 0], [0, 0, 1])
    proj = p.computeProjectionMatrixFOV(45, 640 / 480, 0.05, 5.0)
    assert _project(view, proj, (0, 0, 0), 640, 480) == (320, 240)
    side = _project(view, proj, (0, 0.5, 0), 640, 480)  # camera right = forward x up = +y
    up = _project(view, proj, (0, 0, 0.5), 640, 480)
    assert side is not None and side[1] == 240 and side[0] > 320
    assert up is not None and up[0] == 320 and up[1] < 240
