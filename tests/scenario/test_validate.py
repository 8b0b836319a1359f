"""`flexhrc scenario validate`: one line per fault, FILE:LINE: message, exit 2 (a test per kind)."""

from __future__ import annotations

from flexhrc.cli import main

from .helpers import base, line_of, write


def validate(capsys, path):
    code = main(["scenario", "validate", str(path)])
    out = capsys.readouterr()
    return code, out.out.strip().splitlines(), out.err.strip().splitlines()


def test_a_valid_file_is_one_summary_line(tmp_path, capsys):
    path = write(tmp_path, base())
    code, out, err = validate(capsys, path)
    assert code == 0 and err == []
    assert out == [
        f"{path}: valid: two_parts: 1 graph(s), 1 layer(s), 3 nodes / 2 hyper-arcs online; "
        "2 actions, 0 processes; robots arm; operators human (passive); 2 objects, 1 places"
    ]


def test_unknown_action_in_a_hyper_arc(tmp_path, capsys):
    doc = base()
    doc["graphs"]["two_parts"]["hyperarcs"][1]["actions"] = ["grab(?who, ?q)"]
    path = write(tmp_path, doc)
    code, _, err = validate(capsys, path)
    assert code == 2
    assert err == [
        f"{path}:{line_of(path, '- name: put_second')}: hyper-arc 'put_second': unknown action "
        "'grab' (actions: pick, put)"
    ]


def test_action_parameter_of_an_undeclared_type(tmp_path, capsys):
    doc = base()
    doc["domain"]["actions"]["pick"]["parameters"]["?p"] = "widget"
    path = write(tmp_path, doc)
    code, _, err = validate(capsys, path)
    assert code == 2
    line = line_of(path, "parameters:")  # pick's parameters come first
    assert (
        f"{path}:{line}: action 'pick': parameter ?p of undeclared type 'widget' (no object, "
        "place, agent or supertype has it)"
    ) in err


def test_undeclared_agent(tmp_path, capsys):
    doc = base()
    doc["domain"]["actions"]["put"]["agents"] = {"single": "robby"}
    path = write(tmp_path, doc)
    code, _, err = validate(capsys, path)
    assert code == 2
    lines = [i for i, t in enumerate(path.read_text().splitlines(), 1) if "agents:" in t]
    assert err == [
        f"{path}:{lines[-1]}: action 'put': undeclared agent 'robby' (agents: human, arm)"
    ]


def test_an_operator_that_is_no_agent(tmp_path, capsys):
    doc = base()
    doc["humans"] = [{"name": "bob", "profile": "passive"}]
    path = write(tmp_path, doc)
    code, _, err = validate(capsys, path)
    assert code == 2
    assert err == [
        f"{path}:{line_of(path, 'name: bob')}: operator 'bob': undeclared agent (declare it "
        "under domain agents with kind: human)"
    ]


def test_object_of_an_unknown_type(tmp_path, capsys):
    doc = base()
    doc["world"]["objects"]["c"] = {"type": "prat", "position": [0.5, 0.0, 0.0]}
    path = write(tmp_path, doc)
    code, _, err = validate(capsys, path)
    assert code == 2
    assert err == [
        f"{path}:{line_of(path, '  c:')}: object 'c' of unknown type 'prat' (the domain's "
        "types: part, place; or map it under world.supertypes)"
    ]


def test_malformed_pose(tmp_path, capsys):
    doc = base()
    doc["world"]["objects"]["a"]["position"] = [0.4, 0.2]
    doc["world"]["places"]["tray"] = [0.5, "x", 0.0]
    path = write(tmp_path, doc)
    code, _, err = validate(capsys, path)
    assert code == 2
    assert err == [
        f"{path}:{line_of(path, 'position: [0.4, 0.2]')}: object 'a': malformed pose position: "
        "[0.4, 0.2] (three finite numbers [x, y, z] in metres)",
        f"{path}:{line_of(path, 'tray:')}: place 'tray': malformed pose [0.5, 'x', 0.0] (three "
        "finite numbers [x, y, z])",
    ]


def test_a_hyper_arc_no_declared_agent_can_do(tmp_path, capsys):
    doc = base()
    doc["domain"]["actions"]["weld"] = {
        "parameters": {"?w": "welder", "?p": "part"},
        "agents": {"choice": "?w"},
    }
    doc["world"]["supertypes"] = {"welder": "agent"}
    doc["graphs"]["two_parts"]["hyperarcs"][1]["actions"] = ["weld(?w, ?q)"]
    path = write(tmp_path, doc)
    code, _, err = validate(capsys, path)
    assert code == 2
    assert err == [
        f"{path}:{line_of(path, '- name: put_second')}: hyper-arc 'put_second': no declared "
        "agent can do 'weld(?w, ?q)' (agents: human, arm)"
    ]


def test_a_predicate_nothing_makes_true_is_a_warning(tmp_path, capsys):
    doc = base()
    doc["domain"]["actions"]["put"]["pre"] = ["holding(?who, ?p)", "clean(?to)"]
    path = write(tmp_path, doc)
    code, out, err = validate(capsys, path)
    assert code == 0 and err == []
    assert out[0] == (
        f"{path}:{line_of(path, 'clean(?to)')}: warning: action 'put': precondition: predicate "
        "'clean' is in no fact and no effect: clean(?to) can never become true"
    )
    assert out[1].startswith(f"{path}: valid: ")


def test_a_missing_graph_file(tmp_path, capsys):
    doc = base()
    del doc["graphs"]
    doc["graph"] = "nowhere.yaml"
    path = write(tmp_path, doc)
    code, _, err = validate(capsys, path)
    assert code == 2
    assert err == [
        f"{path}:{line_of(path, 'graph: nowhere.yaml')}: graph file 'nowhere.yaml' not found "
        f"(looked for {tmp_path / 'nowhere.yaml'})"
    ]


def test_an_invalid_graph_file_reports_its_own_file_and_line(tmp_path, capsys):
    graph = tmp_path / "broken.txt"
    graph.write_text("G 2 root\nroot 0\nleaf zero\n")
    doc = base()
    del doc["graphs"]
    doc["graph"] = "broken.txt"
    path = write(tmp_path, doc)
    code, _, err = validate(capsys, path)
    assert code == 2
    assert len(err) == 1 and err[0].startswith(f"{graph}:3: ")


def test_every_fault_at_once_and_run_refuses_with_the_first(tmp_path, capsys):
    doc = base()
    doc["graphs"]["two_parts"]["hyperarcs"][1]["actions"] = ["grab(?who, ?q)"]
    doc["world"]["objects"]["a"]["position"] = [0.4, 0.2]
    path = write(tmp_path, doc)
    code, _, err = validate(capsys, path)
    assert code == 2 and len(err) == 2
    assert main(["run", str(path), "--quiet"]) == 2
    run_err = capsys.readouterr().err.strip()
    assert run_err.startswith("error: ") and "\n" not in run_err
    assert "(and 1 more: flexhrc scenario validate)" in run_err
