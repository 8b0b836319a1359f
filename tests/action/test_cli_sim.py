"""``flexhrc sim``: JSON keys, exit codes, errors naming the argument, headless view."""

from __future__ import annotations

import json

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
