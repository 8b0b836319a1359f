"""The probe of 2026-12-02, sections 16-20: scenario files, legacy files and CLI options.

Each case of the report is one row, keyed by its id: the file or the command line the probe
used, and the one clear error (``FILE:LINE: message``, exit 2) or result that is right.
"""

from __future__ import annotations

import random
from pathlib import Path

import pytest

from flexhrc.cli import main

REPO = Path(__file__).resolve().parents[2]
LID = (REPO / "examples" / "scenarios" / "lid_task.yaml").read_text()

OBJ = "size: [0.30, 0.20, 0.01]}"

#: id: (old text of lid_task.yaml, new text, the line's text, the message after FILE:LINE: )
LID_CASES: dict[str, tuple[str, str, str, str]] = {
    "S01": (OBJ, "size: [0.30, 0.20, 0.01], attrs: abc}", "lid:", "object 'lid': attrs must be"),
    "S02": (OBJ, "size: [0.30, 0.20, 0.01], attrs: [1, 2]}", "lid:", "attrs must be a mapping"),
    "S03": (OBJ, "size: [0.30, 0.20, 0.01], reachable_by: 5}", "lid:", "reachable_by must be"),
    "S04": (
        OBJ,
        "size: [0.30, 0.20, 0.01], reachable_by: arm}",
        "lid:",
        "object 'lid': reachable_by must be a list of agent names, such as [arm], got 'arm'",
    ),
    "S05": ("fixed: true}", "fixed: 'no'}", "box:", "object 'box': fixed must be true or false"),
    "S06": ("types: [robot]", "types: robot", "arm:", "agent 'arm': types must be a list"),
    "S07": ("types: [robot]", "types: 5", "arm:", "agent 'arm': types must be a list"),
    "S08": ("reach: 0.9", "reach: far", "arm:", "agent 'arm': reach must be a number"),
    "S09": ("reach: 0.9", "reach: -1", "arm:", "reach must be a number of metres in (0, 10]"),
    "S10": ("reach: 0.9", "reach: .nan", "arm:", "reach must be a number of metres"),
    "S11": ("reach: 0.9", "reach: 0.9, speed: 0", "arm:", "agent 'arm': speed must be"),
    "S12": ("reach: 0.9", "reach: 0.9, speed: -2", "arm:", "speed must be a number of m/s"),
    "S17": ("flexhrc: 1", "flexhrc: true", "flexhrc:", "unsupported scenario format True"),
    "S19": (
        'add: ["on_box(?l)"]',
        'add: ["on_box(?l)", "on_box(?zz)"]',
        "add: [",
        "action 'carry': add uses ?zz, which is no parameter",
    ),
    "S21": (
        "  - {name: human, profile: cooperative, speed: 1.0}",
        "  - {name: human, profile: cooperative, speed: 1.0}\n  - {name: human, profile: takeover}",
        "{name: human, profile: takeover}",
        "operator 'human': listed twice under humans",
    ),
    "S22": (
        "  facts: [",
        "  supertypes: {lid: thing, thing: lid}\n  facts: [",
        "supertypes:",
        "world.supertypes form a cycle: lid -> thing -> lid",
    ),
    "S25": (
        'agents: {choice: "?who"}\n      pre: ["on_table',
        'agents: {joint: [human, arm]}\n      pre: ["on_table',
        "agents: {joint",
        "action 'carry': joint agents must be robot arms; human is a human",
    ),
    "bound": (
        "position: [0.40, 0.25, 0.0]",
        "position: [1.0e+300, 0.25, 0.0]",
        "lid:",
        "object 'lid': position [1e+300, 0.25, 0.0] is outside the workspace",
    ),
}


def lid_file(tmp_path: Path, case: str, old: str, new: str) -> Path:
    assert old in LID, old
    path = tmp_path / f"{case}.yaml"
    path.write_text(LID.replace(old, new, 1))
    return path


def line_of(path: Path, text: str) -> int:
    for i, line in enumerate(path.read_text().splitlines(), 1):
        if text in line:
            return i
    raise AssertionError(f"{text!r} not in {path}")


def error_lines(capsys: pytest.CaptureFixture[str]) -> list[str]:
    captured = capsys.readouterr()
    assert "Traceback" not in captured.err
    return [line for line in (captured.err + captured.out).splitlines() if line.strip()]


@pytest.mark.parametrize("case", sorted(LID_CASES))
def test_bad_scenario_values_are_refused_at_their_line(case, tmp_path, capsys):
    """S01-S12, S17, S19, S21, S22, S25: `scenario validate` names the file, the line and the
    key; never a traceback, never a coerced value (S04: 'arm' is not ['a', 'r', 'm'])."""
    old, new, at, message = LID_CASES[case]
    path = lid_file(tmp_path, case, old, new)
    assert main(["scenario", "validate", str(path)]) == 2
    lines = error_lines(capsys)
    where = f"{path}:{line_of(path, at)}: "
    assert any(line.startswith(where) and message in line for line in lines), lines


@pytest.mark.parametrize("case", ["S01", "S04", "S08"])
def test_run_and_cell_refuse_what_validate_refuses(case, tmp_path, capsys):
    """S01/S07 run, S08r (run crashed on reach: far), CF16 (`flexhrc cell` took S01): the
    same one error, exit 2, before anything runs."""
    old, new, at, message = LID_CASES[case]
    path = lid_file(tmp_path, case, old, new)
    for argv in (["run", str(path)], ["cell", str(path)]):
        assert main(argv) == 2
        lines = error_lines(capsys)
        assert any(f"{path}:{line_of(path, at)}: " in x and message in x for x in lines), lines


def test_s18_a_free_variable_in_a_precondition_means_some_object(tmp_path, capsys):
    """S18: `pre: [on_table(?zz)]` is read as "some object is on the table" (the shipped
    ball_in_box's `check` needs `in(?b, ?box)`: some ball in the box); only an effect's free
    variable is an error (S19)."""
    path = lid_file(
        tmp_path, "S18", 'pre: ["on_table(?l)"]', 'pre: ["on_table(?l)", "on_table(?zz)"]'
    )
    assert main(["scenario", "validate", str(path)]) == 0
    assert "valid" in capsys.readouterr().out


def test_s32v_nested_aliases_are_refused_at_once(tmp_path, capsys):
    """S32v: a 400-byte file whose aliases stand for 10**8 values is refused by the reader,
    with a short message, instead of 640 MB and a 522 MB error line."""
    lines = ["flexhrc: 1", "a: &a [x,x,x,x,x,x,x,x,x,x]"]
    prev = "a"
    for name in "bcdefgh":
        lines.append(f"{name}: &{name} [" + ",".join([f"*{prev}"] * 10) + "]")
        prev = name
    lines.append("world: {facts: *h}")
    path = tmp_path / "S32.yaml"
    path.write_text("\n".join(lines) + "\n")
    assert len(path.read_bytes()) < 500
    for argv in (["scenario", "validate", str(path)], ["run", str(path)]):
        assert main(argv) == 2
        out = error_lines(capsys)
        assert len("".join(out)) < 500
        assert any("YAML aliases expand to more than" in x for x in out), out


def test_a_recursive_alias_is_refused(tmp_path, capsys):
    path = tmp_path / "rec.yaml"
    path.write_text("flexhrc: 1\nname: &a [1, *a]\n")
    assert main(["scenario", "validate", str(path)]) == 2
    assert any("recursive" in x for x in error_lines(capsys))


def test_ordinary_aliases_still_read(tmp_path):
    from flexhrc.representation.formats.yaml_format import read_yaml

    path = tmp_path / "ok.yaml"
    path.write_text("a: &a [1, 2]\nb: [*a, *a]\n")
    assert read_yaml(path) == {"a": [1, 2], "b": [[1, 2], [1, 2]]}


#: CF cases: the legacy file's text, the key's line, the message (section 17)
LEGACY: dict[str, tuple[str, int, str]] = {
    "CF01": ("scenario: table_assembly\nlegs: 2.7\n", 2, "legs: expected a whole number"),
    "CF02": (
        'scenario: table_assembly\nunreachable_bolts: "12"\n',
        2,
        "unreachable_bolts: expected a list of bolt numbers",
    ),
    "CF03": ("scenario: table_assembly\nlegs: .inf\n", 2, "legs: expected a whole number"),
    "CF04": ("scenario: table_assembly\nlegs: 30\n", 2, "legs: 30: too many"),
    "CF05": (
        "scenario: table_assembly\nlegs: 4\nleg_positions: [[0.1, 0.1, 0], [0.2, 0.2, 0]]\n",
        3,
        "leg_positions: gives 2 positions for 4 legs",
    ),
    "CF06": ('scenario: table_assembly\nhuman: "no"\n', 2, "human: expected true or false"),
    "CF07": ("scenario: parallel_assembly\narms: 0\n", 2, "arms must be in 1..64, got 0"),
    "CF08": ("scenario: parallel_assembly\narms: -3\n", 2, "arms must be in 1..64, got -3"),
    "CF09": ("scenario: table_assembly\nlegs: 100000\n", 2, "legs: 100000: too many"),
    "CF10": ('scenario: parallel_assembly\nchain: "no"\n', 2, "chain: expected true or false"),
    "CF11": (
        "scenario: parallel_assembly\nlegs: 4\nhuman_legs: 5\n",
        3,
        "human_legs must be in 0..legs (4), got 5",
    ),
}

#: CF17 (agent robot), CF18 / RC20 (agent, ros2 cell): every front end reads the one converter
FRONT_ENDS = {
    "run": ["run", "{f}"],
    "cell": ["cell", "{f}"],
    "agent_robot": ["agent", "robot", "{f}", "--arm", "left", "--connect", "tcp/127.0.0.1:9"],
    "agent_human": [
        "agent",
        "human",
        "{f}",
        "--name",
        "human",
        "--connect",
        "tcp/127.0.0.1:9",
    ],
    "ros2_cell": ["ros2", "cell", "{f}", "--wait", "1"],
}


@pytest.mark.parametrize("front", sorted(FRONT_ENDS))
@pytest.mark.parametrize("case", sorted(LEGACY))
def test_legacy_files_have_one_reader(case, front, tmp_path, capsys):
    """CF01-CF11, CF17, CF18, RC20: `cell`, `agent` and `ros2 cell` refuse what `run` refuses,
    with the file and the key's line (one message, not the file named twice: CF10)."""
    text, line, message = LEGACY[case]
    path = tmp_path / f"{case}.yaml"
    path.write_text(text)
    argv = [a.format(f=path) for a in FRONT_ENDS[front]]
    assert main(argv) == 2
    lines = error_lines(capsys)
    assert any(x.startswith(f"error: {path}:{line}: ") and message in x for x in lines), lines
    assert not any(x.count(str(path)) > 1 for x in lines), lines


def test_rn04_a_scripted_step_past_the_last_is_refused(capsys):
    """RN04: ball_in_box has three steps; `--human-takes 9` is refused, not ignored."""
    assert main(["run", "ball_in_box", "--human-takes", "9"]) == 2
    assert any("--human-takes 9: ball_in_box has at most 3 steps" in x for x in error_lines(capsys))


def test_rn15_scenario_new_with_an_empty_name_writes_nothing(tmp_path, monkeypatch, capsys):
    """RN15: `flexhrc scenario new ''` wrote scenario.yaml into the current folder."""
    monkeypatch.chdir(tmp_path)
    assert main(["scenario", "new", ""]) == 2
    assert any("DIR is empty" in x for x in error_lines(capsys))
    assert not (tmp_path / "scenario.yaml").exists()


#: section 20: CLI options. id: (argv, the message)
OPTIONS: dict[str, tuple[list[str], str]] = {
    "CA19": (["cell", "table_assembly", "--seed", "-1"], "--seed: must be in [0, 4294967295]"),
    "CA20": (
        ["cell", "table_assembly", "--seed", "1180591620717411303424"],
        "--seed: must be in [0, 4294967295]",
    ),
    "CA33": (
        ["agent", "human", "table_assembly", "--name", "human", "--seed", "-5"],
        "--seed: must be in [0, 4294967295]",
    ),
    "CA33r": (["ros2", "cell", "table_assembly", "--seed", "-5"], "--seed: must be in"),
    "CA33b": (["behave", "(THEN a b)", "--seed", "-5"], "--seed: must be in"),
    "CA35": (
        ["agent", "robot", "table_assembly", "--arm", "left", "--connect", "tcp/127.0.0.1:0"],
        "--connect tcp/127.0.0.1:0: port 0 is no port to connect to",
    ),
}


@pytest.mark.parametrize("case", sorted(OPTIONS))
def test_cli_options_are_refused_alike(case, capsys):
    """CA19/CA20/CA33: one --seed range in every command; CA35: no cell listens on port 0."""
    argv, message = OPTIONS[case]
    assert main(argv) == 2
    lines = error_lines(capsys)
    assert any(message in x for x in lines), lines


def test_rc12_a_ros2_cell_names_the_ros2_nodes_to_start(capsys, monkeypatch):
    """RC12: `ros2 cell --wait 1` said to start the Zenoh agents, not `flexhrc ros2 arm|human`."""
    pytest.importorskip("rclpy")
    # its own discovery settings: it passed only after tests/ros2/conftest.py had set them
    monkeypatch.setenv("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    monkeypatch.setenv("ROS_DOMAIN_ID", str(random.SystemRandom().randint(1, 100)))
    assert main(["ros2", "cell", "table_assembly", "--wait", "1", "--cell", "rc12"]) == 2
    lines = error_lines(capsys)
    assert any("flexhrc ros2 arm SCENARIO --arm NAME" in x for x in lines), lines
    assert not any("flexhrc agent robot" in x for x in lines), lines


def test_r12_a_query_does_not_walk_the_done_part_of_a_deep_chain(monkeypatch):
    """R12: playing an n-node chain to the end recomputed the outside cost of everything
    already done below the frontier at every query (about 2 n**2 in all). Counted, not
    timed: the top-down pass queues O(n) elements over the whole play."""
    import flexhrc.representation.online as online_mod
    from flexhrc.representation import HierarchicalGraph
    from flexhrc.representation.play import play
    from flexhrc.representation.synthetic import chain

    queued = 0
    real = online_mod.heappush

    def counting(heap, item):  # type: ignore[no-untyped-def]
        nonlocal queued
        queued += 1
        real(heap, item)

    monkeypatch.setattr(online_mod, "heappush", counting)
    n = 400
    report = play(HierarchicalGraph.single(chain(n)), "cheapest")
    assert report.outcome == "solved" and report.queries == 2 * n
    assert queued <= 4 * n, queued  # was 318 004 (about 2 n**2)


@pytest.mark.parametrize(
    "position, message",
    [
        ("[1e300, 0, 0]", "position [1e+300, 0, 0] is outside the workspace"),
        ("[.inf, 0, 0]", "position must be"),
        ("[.nan, 0, 0]", "position must be"),
    ],
)
def test_b21_a_behave_world_object_far_away_is_refused_at_load(position, message, tmp_path, capsys):
    """B21: an object at [1e300, 0, 0] ran 52 000 ticks to a timeout (numpy overflow
    warnings); it is refused when the task file is read, at its line."""
    path = tmp_path / "b21.yaml"
    path.write_text(
        "task:\n  THEN: [placemat, plate]\nworld:\n  objects:\n"
        f"    placemat: {{position: {position}, target: [0.8, 0.0, 0.75]}}\n"
        "    plate: {position: [0.5, 0.2, 0.75], target: [0.8, 0.2, 0.75]}\n"
    )
    assert main(["behave", str(path)]) == 2
    lines = error_lines(capsys)
    assert any(f"{path}:5: object 'placemat' {message}" in x for x in lines), lines


def test_t14_a_url_given_to_web_is_named_as_such(capsys):
    """T14: `--web http://127.0.0.1:0/` said to write an IPv6 address as [ADDRESS]:PORT."""
    assert main(["panel", "--web", "http://127.0.0.1:0/"]) == 2
    lines = error_lines(capsys)
    assert any("give HOST:PORT, not a URL" in x for x in lines), lines
    assert not any("write an IPv6 address" in x for x in lines), lines


def test_t15_the_panel_on_another_loopback_address_answers_it():
    """T15: `panel --web 127.0.0.2:PORT` (loopback, so no token asked) refused every request:
    the Host check knew 127.0.0.1 only; all of 127.0.0.0/8 and ::1 are this machine."""
    pytest.importorskip("starlette")
    from flexhrc.web.server import is_loopback  # the rule the app's Host check applies

    assert all(is_loopback(h) for h in ("127.0.0.1", "127.0.0.2", "127.1.2.3", "::1", "localhost"))
    assert not any(is_loopback(h) for h in ("evil.example", "10.0.0.1", "0.0.0.0", "", "::"))


def test_t11_panel_legs_does_not_suggest_an_option_panel_lacks(capsys):
    """T11: `panel --legs 40` suggested `tabletop 0.65x0.65 would do`; panel has no
    --tabletop, so the message says what holds and stops there."""
    assert main(["panel", "--legs", "40"]) == 2
    lines = error_lines(capsys)
    assert any("--legs 40: too many" in x for x in lines), lines
    assert not any("would do" in x or "tabletop:" in x for x in lines), lines


@pytest.mark.parametrize(
    "where, old, new, message",
    [
        ("node state", '"on_box(?l)"}', "5}", "state must be a formula"),
        ("pre", 'pre: ["on_table(?l)"]', "pre: 5", "expected a list of literals"),
        ("choice", 'agents: {choice: "?who"}', "agents: {choice: [1, 2]}", "takes one name"),
    ],
)
def test_values_of_the_wrong_kind_in_graph_and_domain_are_refused(
    where, old, new, message, tmp_path, capsys
):
    """Found by mutating lid_task.yaml's every value (2584 files, the probe's way): a node
    state, a precondition or an agent choice of the wrong kind was a TypeError traceback."""
    path = lid_file(tmp_path, where.replace(" ", "_"), old, new)
    assert main(["scenario", "validate", str(path)]) == 2
    assert any(message in x and f"{path}:" in x for x in error_lines(capsys))


def test_a_legacy_table_with_an_astronomic_leg_count_is_refused_at_once(tmp_path, capsys):
    """`legs: 1e30` as a whole number listed every leg's name before checking the capacity."""
    path = tmp_path / "big.yaml"
    path.write_text("scenario: table_assembly\nlegs: 1000000000000000000000000000000\n")
    assert main(["run", str(path)]) == 2
    assert any(f"{path}:2: legs: " in x and "too many" in x for x in error_lines(capsys))
