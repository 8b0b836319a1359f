import json

import pytest

from flexhrc.cli import main
from flexhrc.scenario.builtin.table_setting import PAPER_ORDERS


def run_cli(capsys, *argv):
    code = main(["behave", *argv])
    out, err = capsys.readouterr()
    return code, out, err


def test_table_setting_json_contract(capsys):
    code, out, _ = run_cli(capsys, "table-setting", "--layout", "2", "--json")
    assert code == 0
    data = json.loads(out)
    for key in ("outcome", "order", "ticks", "resets"):
        assert key in data
    assert data["outcome"] == "done"
    assert data["order"] == PAPER_ORDERS[2]
    assert data["resets"] == 0 and data["ticks"] > 0
    assert data["violations"] == []
    assert data["arms"] == ["arm"]


def test_human_output_has_trace_and_summary_and_plot(capsys, tmp_path):
    png = tmp_path / "gantt.png"
    code, out, _ = run_cli(capsys, "table-setting-robustness", "--plot", str(png))
    assert code == 0
    assert "RESET  fork" in out and "RESET  knife" in out
    assert "outcome: done" in out and "resets: 2" in out
    assert "constraints: respected" in out
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_two_arms_and_seed_and_log_file(capsys, tmp_path):
    log = tmp_path / "log.jsonl"
    code, out, _ = run_cli(
        capsys, "table-setting", "--arms", "2", "--seed", "3", "--json", "--log", str(log)
    )
    assert code == 0
    data = json.loads(out)
    assert data["arms"] == ["left", "right"] and data["seed"] == 3
    events = [json.loads(line) for line in log.read_text().splitlines()]
    assert sum(1 for e in events if e["kind"] == "done") == len(data["order"])


def test_inline_task_and_task_files(capsys, tmp_path):
    code, out, _ = run_cli(capsys, "(THEN a (AND b c))", "--json", "--seed", "5")
    assert code == 0 and json.loads(out)["order"][0] == "a"
    txt = tmp_path / "task.txt"
    txt.write_text("# the Fig. 1 task\n(THEN a (AND (THEN b c) (OR d e (THEN f g))))\n")
    code, out, _ = run_cli(capsys, str(txt), "--json")
    data = json.loads(out)
    assert code == 0 and data["outcome"] == "done" and data["order"][0] == "a"
    yml = tmp_path / "task.yaml"
    yml.write_text(
        "task: {THEN: [x, y]}\nworld:\n  objects:\n"
        "    x: {position: [0.5, 0, 0.75]}\n    y: {position: [0.6, 0.1, 0.75]}\n"
    )
    code, out, _ = run_cli(capsys, str(yml), "--json", "--arms", "2")
    data = json.loads(out)
    assert code == 0 and data["order"] == ["x", "y"] and data["arms"] == ["left", "right"]


def test_render_ascii_and_dot(capsys):
    code, out, _ = run_cli(capsys, "table-setting", "--render", "ascii")
    assert code == 0 and out.startswith("THEN (THEN_1)") and "└── OR (OR_1)" in out
    code, out, _ = run_cli(capsys, "(OR a b)", "--render", "dot")
    assert code == 0 and out.startswith('digraph "task"') and '"OR_1" -> "b";' in out


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["table-settin"], "unknown scenario 'table-settin' (known: table-setting"),
        (["table-setting", "--layout", "4"], "layouts 1, 2 and 3"),
        (["(THEN a (AND b c)"], "<inline task>:1: column 1: '(' is never closed"),
        (["(THEN a (XOR b c))"], "column 10: expected THEN, AND or OR"),
        (["missing.yaml"], "missing.yaml: no such file"),
        (["table-setting-robustness", "--layout", "2"], "--layout only applies"),
    ],
)
def test_bad_input_is_one_line_exit_2(capsys, argv, message):
    code, out, err = run_cli(capsys, *argv)
    assert code == 2
    assert out == ""
    assert message in err
    assert err.startswith("error: ") and err.count("\n") == 1 and "Traceback" not in err


def test_yaml_errors_name_file_and_line(capsys, tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("task:\n  THEN:\n    - a\n    - {XOR: [b]}\n")
    code, _, err = run_cli(capsys, str(bad))
    assert code == 2 and f"{bad}:4: unknown goal type 'XOR'" in err
    unknown = tmp_path / "unknown.yaml"
    unknown.write_text(
        "task: {THEN: [a, fork]}\nworld:\n  objects:\n    a: {position: [0.5, 0, 0.75]}\n"
    )
    code, _, err = run_cli(capsys, str(unknown))
    assert code == 2
    assert (
        f"{unknown}:1: column 18: behaviour 'fork' has no object in the world (objects: a)" in err
    )


def test_plot_without_matplotlib_is_a_clear_error(capsys, monkeypatch):
    import sys

    monkeypatch.setitem(sys.modules, "matplotlib", None)  # makes `import matplotlib` fail
    code, out, err = run_cli(capsys, "(AND a b)", "--plot", "never.png")
    assert code == 2 and out == ""
    assert "needs the optional dependency 'matplotlib'" in err and "flexhrc[viz]" in err
