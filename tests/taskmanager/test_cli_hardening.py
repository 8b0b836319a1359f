"""Bad inputs of `demo table`, `run` and `replay` (issue 9; review cases A-D of
../shared/reviews/bad-input-probe-2026-12-01.md): one error line naming the option or the file
and line, exit 2, no traceback; outputs checked before the work; streamed, locked logs."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from flexhrc.cli import main
from flexhrc.files import EventLogWriter

from ..conftest import subprocess_env

FAST = ["--simulator", "analytic", "--quiet"]


def _error(capsys) -> str:
    err = capsys.readouterr().err
    assert "Traceback" not in err
    lines = [line for line in err.splitlines() if line.startswith("error:") or ": error:" in line]
    assert len(lines) == 1, err
    return lines[0]


# -- demo table options ------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("argv", "expected"),
    [
        (["--legs", "24"], "--legs 24: too many for a 0.3 x 0.4 m tabletop"),  # A1
        (["--legs", "24"], "--tabletop 0.4x0.4 holds them"),
        (["--tabletop", "huge"], "--tabletop 'huge' is not a tabletop"),
        (["--tabletop", "0.01x9"], "--tabletop sides must be between"),
        (["--tabletop", "nanxnan"], "--tabletop sides must be finite"),
        (["--human-takes", "9"], "--human-takes 9: not one of the bolts 1..4"),  # C1
        (["--human-takes", "0"], "--human-takes 0: not one of the bolts 1..4"),
        (["--no-human", "--human-takes", "2"], "--human-takes needs a human"),  # C3
        (["--fail", "fly:1"], "--fail 'fly:1': unknown robot action 'fly'"),  # C2
        (["--fail", "transport:0"], "N must be at least 1"),
        (["--fail", "transport:-1"], "N must be at least 1"),
        (["--fail", ""], "--fail '': expected ACTION or ACTION:N"),
        (["--fail", "transport:"], "expected ACTION or ACTION:N"),
        (
            ["--disturb", "blocked_path:fly:1", "--simulator", "kinematic"],
            "--disturb 'blocked_path:fly:1': unknown robot action 'fly'",
        ),
        (["--disturb", "slow_arm:transport:0", "--simulator", "kinematic"], "N must be at least"),
        (["--realtime", "-1"], "argument --realtime: must be a finite number in (0, 1e+06]"),  # C4
        (["--realtime", "nan"], "argument --realtime: must be a finite number in (0, 1e+06]"),
        (["--realtime", "inf"], "argument --realtime"),
        (["--seed", "-5"], "argument --seed: must be in [0, 4294967295], got -5"),
        (["--legs", "99999999"], "argument --legs: must be <= 10000"),
        (["--plot", "timeline.xyz"], "--plot timeline.xyz: unsupported output format '.xyz'"),  # B9
        (["--log", "/dev/full"], "--log /dev/full: not a regular file"),  # A8
    ],
)
def test_bad_demo_options_are_one_error_before_the_run(
    argv, expected, capsys, tmp_path, monkeypatch
):
    monkeypatch.chdir(tmp_path)
    assert main(["demo", "table", *FAST, *argv]) == 2
    assert expected in _error(capsys)  # argparse's errors: a usage line, then one error line
    assert not list(tmp_path.iterdir())  # nothing written


def test_outputs_are_checked_before_the_work_and_no_folder_is_created(tmp_path, capsys):
    missing = tmp_path / "nonexistent"
    # C5: --plot into a missing folder is refused, and the folder is not created
    assert main(["demo", "table", *FAST, "--plot", str(missing / "t.png")]) == 2
    assert f"--plot {missing / 't.png'}: folder {missing} does not exist" in _error(capsys)
    assert not missing.exists()
    # A8: the same for --log, and a folder given as the log
    assert main(["demo", "table", *FAST, "--log", str(missing / "run.jsonl")]) == 2
    assert "does not exist" in _error(capsys)
    assert main(["demo", "table", *FAST, "--log", str(tmp_path)]) == 2
    assert "is a folder" in _error(capsys)
    # one file for both outputs
    same = tmp_path / "x.png"
    assert main(["demo", "table", *FAST, "--log", str(same), "--plot", str(same)]) == 2
    assert "also given to --log" in _error(capsys)
    assert not missing.exists() and not same.exists()


def test_an_output_never_overwrites_the_scenario_file(tmp_path, capsys):
    f = tmp_path / "s.yaml"
    f.write_text("scenario: table_assembly\nlegs: 1\n")
    assert main(["run", str(f), *FAST, "--log", str(f)]) == 2
    assert "is an input of this command" in _error(capsys)
    assert f.read_text() == "scenario: table_assembly\nlegs: 1\n"


def test_a_failure_that_never_happens_is_reported(capsys):
    code = main(["demo", "table", *FAST, "--fail", "transport:99", "--json"])
    captured = capsys.readouterr()
    assert code == 0
    assert "warning: --fail transport:99 never happened: the run had 4 transport actions" in (
        captured.err
    )


def test_the_simulator_asked_for_is_the_one_used(capsys):
    # A3: --simulator analytic was silently replaced by the kinematic default
    assert main(["demo", "table", "--simulator", "analytic", "--json", "--quiet"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["simulator"] == "analytic"
    # the analytic simulator takes well under a millisecond per branch; the kinematic ~50 ms
    assert data["timing"]["simulator_s"] < 0.05 * data["branches_simulated"]


def test_reachable_only_by_is_honoured_with_the_analytic_simulator(tmp_path, capsys):
    # A4: the left arm connected a leg only the right arm may reach
    f = tmp_path / "s.yaml"
    f.write_text(
        "scenario: table_assembly\nlegs: 2\nreachable_only_by: {leg1: right, leg2: right}\n"
    )
    assert main(["run", str(f), "--simulator", "analytic", "--json", "--quiet"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["simulator"] == "analytic"
    assert data["legs_by_agent"]["right"] == 2 and data["legs_by_agent"]["left"] == 0


def test_sixty_legs_on_a_large_enough_tabletop(capsys):
    code = main(
        ["demo", "table", "--legs", "60", "--tabletop", "0.9x0.9", *FAST, "--json", "--seed", "3"]
    )
    data = json.loads(capsys.readouterr().out)
    assert code == 0 and data["outcome"] == "solved"
    assert sum(data["legs_by_agent"].values()) == 60


# -- scenario files ----------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("body", "line", "expected"),
    [
        ("legs: .inf\n", 2, "legs: expected a whole number, got inf"),  # B10
        ("legs: .nan\n", 2, "legs: expected a whole number, got nan"),
        ("legs: 2.7\n", 2, "legs: expected a whole number, got 2.7"),  # C7
        ("legs: true\n", 2, "legs: expected a whole number, got True"),
        ("legs: -2\n", 2, "legs: must be at least 1, got -2"),  # D: no --legs
        ("legs: 30\n", 2, "legs: 30: too many for a 0.3 x 0.4 m tabletop"),  # A1
        ("legs: 30\n", 2, "tabletop: 0.5x0.5 holds them"),
        ('human: "no"\n', 2, "human: expected true or false, got 'no'"),
        ('unreachable_bolts: "12"\n', 2, "unreachable_bolts: expected a list"),  # C6
        ("unreachable_bolts: [7]\n", 2, "unreachable_bolts: 7 is not one of the bolts 1..4"),
        ("legs: 4\nleg_positions: [[0.3, 0.3, 0], [0.4, 0.3, 0]]\n", 3, "gives 2 positions"),  # C8
        ("legs: 2\nleg_positions: [[0.3, 0.3, 0], [0.3, 0.3, 0]]\n", 3, "at the same place"),
        ("legs: 1\nleg_positions: [[.nan, 0.3, 0]]\n", 3, "leg1: expected [x, y, z] finite"),
        ("reachable_only_by: {leg1: octopus}\n", 2, "'octopus' is not an arm"),  # C9
        ("reachable_only_by: {leg99: left}\n", 2, "'leg99' is not one of the legs leg1..leg4"),
        ("tabletop: huge\n", 2, "tabletop: 'huge' is not a tabletop"),  # D
        ("leg_length: 3\n", 2, "leg_length: expected one of long, short, got 3"),
        ("profile: lazy\n", 2, "profile: expected one of passive, takeover"),
        ("human: false\nprofile: takeover\n", 3, "profile: takeover needs a human"),  # D
        ("seed: -1\n", 2, "seed: must be a whole number >= 0"),
    ],
)
def test_bad_scenario_values_name_the_file_and_line(body, line, expected, tmp_path, capsys):
    f = tmp_path / "s.yaml"
    f.write_text("scenario: table_assembly\n" + body)
    assert main(["run", str(f), *FAST]) == 2
    err = _error(capsys)
    assert err.startswith(f"error: {f}:{line}: "), err
    assert expected in err
    assert "--" not in err.split(": ", 2)[2].replace("--human", "")  # names no CLI flag


def test_a_large_tabletop_in_a_scenario_file(tmp_path, capsys):
    f = tmp_path / "s.yaml"
    f.write_text("scenario: table_assembly\nlegs: 30\ntabletop: [0.6, 0.6]\n")
    assert main(["run", str(f), *FAST, "--json"]) == 0
    assert sum(json.loads(capsys.readouterr().out)["legs_by_agent"].values()) == 30


@pytest.mark.parametrize(
    ("content", "expected"),
    [
        (bytes(range(256)) * 8, "not a text file (binary data)"),  # B3
        (b"scenario: table_assembly\nlegs: \xca\xfe\n", ":2: not UTF-8 text"),
    ],
)
def test_binary_or_non_utf8_scenario_files(content, expected, tmp_path, capsys):
    f = tmp_path / "b.yaml"
    f.write_bytes(content)
    assert main(["run", str(f)]) == 2
    assert expected in _error(capsys)


def test_a_folder_or_missing_scenario_file(tmp_path, capsys):
    assert main(["run", str(tmp_path)]) == 2
    assert "is a folder" in _error(capsys)
    assert main(["run", str(tmp_path / "none.yaml")]) == 2
    assert "no such file" in _error(capsys)


def test_human_option_against_a_scenario_without_human(tmp_path, capsys):
    f = tmp_path / "s.yaml"
    f.write_text("scenario: table_assembly\nhuman: false\n")
    assert main(["run", str(f), *FAST, "--human", "takeover"]) == 2
    assert f"--human takeover needs a human, but {f}:2: human: false" in _error(capsys)
    assert main(["run", str(f), *FAST, "--human-takes", "1"]) == 2
    assert f"--human-takes needs a human, but {f}:2: human: false" in _error(capsys)


# -- replay ------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def good_log(tmp_path_factory) -> list[str]:
    path = tmp_path_factory.mktemp("log") / "run.jsonl"
    assert main(["demo", "table", *FAST, "--human", "takeover", "--log", str(path)]) == 0
    return path.read_text().splitlines()


def _first(lines: list[str], kind: str) -> int:
    return next(i for i, line in enumerate(lines) if json.loads(line)["type"] == kind)


def _edit(lines: list[str], kind: str, **change) -> list[str]:
    out = list(lines)
    i = _first(out, kind)
    ev = json.loads(out[i])
    for k, v in change.items():
        if v is _DROP:
            ev.pop(k)
        else:
            ev[k] = v
    out[i] = json.dumps(ev)
    return out


_DROP = object()
REPLAY_CASES = [  # (event type, change, expected message) -- B7, C13, C14
    ("action_end", {"t": "abc"}, "'t' must be a finite time >= 0, got 'abc'"),
    ("action_end", {"start": "x"}, "'start' must be a finite time"),
    ("action_end", {"start": _DROP}, "'start' must be a finite time"),
    ("action_end", {"agents": _DROP}, "'agents' must be a list of agent names"),
    ("action_end", {"agents": None}, "'agents' must be a list of agent names"),
    ("action_end", {"agents": "human"}, "'agents' must be a list of agent names"),
    ("action_end", {"status": _DROP}, "'status' must be one of done"),
    ("action_end", {"status": "great"}, "'status' must be one of done"),
    ("action_end", {"action": 5}, "'action' must be a string"),
    ("action_end", {"action": _DROP}, "'action' must be a string"),
    ("decision", {"branches": 7}, "'branches' must be a list"),
    ("decision", {"chosen": 99}, "'chosen' is not one of its"),
    ("outcome", {"outcome": _DROP}, "'outcome' must be one of solved, failed, interrupted"),
    ("outcome", {"outcome": "exploded"}, "got 'exploded'"),
    ("summary", {"timing": "fast"}, "'timing' must be a mapping"),
    ("summary", {"timing": {"simulator_s": "fast"}}, "timing 'simulator_s' must be a finite"),
    ("start", {"agents": 5}, "start: 'agents' must be a list"),
    ("action_end", {"type": "teleport"}, "unknown event type 'teleport'"),
    ("action_end", {"t": -1e9}, "'t' must be a finite time >= 0"),
    ("action_end", {"t": 1000.0}, "time goes back"),
    ("command", {"id": "one"}, "'id' must be a whole number"),
    ("summary", {"timing": {"total_s": 1000.0}}, "the run ended at 1000.0 s but its events"),
]


@pytest.mark.parametrize(("kind", "change", "expected"), REPLAY_CASES)
def test_replay_names_the_bad_line(good_log, kind, change, expected, tmp_path, capsys):
    lines = _edit(good_log, kind, **change)
    path = tmp_path / "bad.jsonl"
    path.write_text("\n".join(lines) + "\n")
    assert main(["replay", str(path)]) == 2
    err = _error(capsys)
    if expected == "time goes back":  # the edited event is fine; the next one goes back
        assert err.startswith(f"error: {path}:{_first(good_log, kind) + 2}: "), err
    else:
        assert err.startswith(f"error: {path}:{_first(good_log, kind) + 1}: "), err
    assert expected in err


@pytest.mark.parametrize("constant", ["NaN", "Infinity", "-Infinity"])
def test_replay_refuses_non_finite_times(good_log, constant, tmp_path, capsys):  # C13
    lines = list(good_log)
    lines[3] = lines[3].replace('"t": ', f'"t": {constant}, "was": ', 1)
    path = tmp_path / "nan.jsonl"
    path.write_text("\n".join(lines) + "\n")
    assert main(["replay", str(path)]) == 2
    assert f"{path}:4: not a JSON line ({constant} is not a JSON number)" in _error(capsys)


def test_replay_refuses_a_log_holding_two_runs(good_log, tmp_path, capsys):  # C12
    path = tmp_path / "dup.jsonl"
    path.write_text("\n".join(good_log + good_log) + "\n")
    assert main(["replay", str(path)]) == 2
    err = _error(capsys)
    assert f"{path}:{len(good_log) + 1}: " in err and "a log holds one run" in err


def test_replay_of_a_folder_binary_or_deeply_nested_file(tmp_path, capsys):  # D, B3, B5
    assert main(["replay", str(tmp_path)]) == 2
    assert f"error: {tmp_path}: is a folder, not a file" == _error(capsys)
    binary = tmp_path / "binary.jsonl"
    binary.write_bytes(b"\x00\xff" * 100)
    assert main(["replay", str(binary)]) == 2
    assert "not a text file (binary data)" in _error(capsys)
    latin = tmp_path / "latin.jsonl"
    latin.write_bytes(b'{"t": 0, "type": "start", "x": "\xe9"}\n')
    assert main(["replay", str(latin)]) == 2
    assert f"{latin}:1: not UTF-8 text" in _error(capsys)
    deep = tmp_path / "deep.jsonl"
    deep.write_text('{"t": 0, "type": "start", "x": ' + "[" * 100_000 + "]" * 100_000 + "}\n")
    assert main(["replay", str(deep)]) == 2
    assert f"{deep}:1: not a JSON line" in _error(capsys)


def unprivileged(argv: list[str]) -> subprocess.CompletedProcess:
    """Run ``python -m flexhrc argv`` without the capabilities that let root read any file
    (as the review did); as a normal user, just run it."""
    import shutil

    cmd = [sys.executable, "-m", "flexhrc", *argv]
    if os.geteuid() == 0:
        setpriv = shutil.which("setpriv")
        if setpriv is None:
            pytest.skip("running as root without setpriv: chmod 000 does not stop root")
        caps = "-dac_override,-dac_read_search"
        cmd = [setpriv, f"--inh-caps={caps}", f"--bounding-set={caps}", *cmd]
    return subprocess.run(cmd, capture_output=True, text=True, env=subprocess_env(), timeout=60)


def test_replay_of_an_unreadable_log(good_log, tmp_path):  # B2
    path = tmp_path / "unread.jsonl"
    path.write_text("\n".join(good_log) + "\n")
    path.chmod(0)
    proc = unprivileged(["replay", str(path)])
    assert proc.returncode == 2 and "Traceback" not in proc.stderr
    assert proc.stderr.strip() == f"error: {path}: cannot read: permission denied"


def test_replay_of_a_log_cut_short(good_log, tmp_path, capsys):
    path = tmp_path / "cut.jsonl"
    path.write_text("\n".join(good_log[: _first(good_log, "outcome")]) + "\n")
    assert main(["replay", str(path), "--json"]) == 0
    captured = capsys.readouterr()
    data = json.loads(captured.out)
    assert data["outcome"] == "cut_short" and data["complete"] is False
    assert "the run was cut short" in data["reason"] and "the run was cut short" in captured.err


def test_replay_plot_is_checked_first_and_never_overwrites_the_log(good_log, tmp_path, capsys):
    path = tmp_path / "run.png"
    path.write_text("\n".join(good_log) + "\n")
    assert main(["replay", str(path), "--plot", str(path)]) == 2
    assert "is an input of this command" in _error(capsys)
    assert main(["replay", str(path), "--plot", str(tmp_path / "no" / "t.png")]) == 2
    assert not (tmp_path / "no").exists()


# -- streamed, locked logs ---------------------------------------------------------------------
def test_a_second_run_on_a_locked_log_is_refused_at_once(tmp_path, capsys):  # A7
    path = tmp_path / "same.jsonl"
    with EventLogWriter(path) as first:
        first.write({"t": 0.0, "type": "start", "agents": ["left"], "profile": "passive"})
        assert main(["demo", "table", *FAST, "--log", str(path)]) == 2
        assert "in use by another flexhrc run" in _error(capsys)
    assert len(path.read_text().splitlines()) == 1  # the first run's log is intact


def test_the_log_is_written_event_by_event(tmp_path):
    """The run's sink sees every event before the run ends (what the CLI streams to --log)."""
    from flexhrc.cell.local import LocalCell
    from flexhrc.scenario.builtin.table import table_assembly
    from flexhrc.taskmanager import AnalyticSimulator

    sc = table_assembly(segments="legs", legs=2)
    seen: list[dict] = []

    def trace(ev):  # the sink got the event before the trace is shown
        assert seen[-1] is ev

    run = LocalCell(
        sc,
        simulator=AnalyticSimulator(),
        observers=[seen.append, trace],
    )
    result = run.run()
    assert seen == result.events and seen[0]["simulator"] == "analytic"


def test_request_stop_ends_the_run_as_interrupted():
    from flexhrc.cell.local import LocalCell
    from flexhrc.scenario.builtin.table import table_assembly
    from flexhrc.taskmanager import AnalyticSimulator

    sc = table_assembly(segments="legs", legs=4)

    def trace(ev):
        if ev["type"] == "action_end":
            run.request_stop("interrupted by SIGINT")

    run = LocalCell(sc, simulator=AnalyticSimulator(), observers=[trace])
    result = run.run()
    assert result.outcome == "interrupted"
    kinds = [e["type"] for e in result.events]
    assert kinds[-2:] == ["outcome", "summary"]
    assert result.events[-2]["reason"] == "interrupted by SIGINT"


def _start(log: Path, *extra: str) -> subprocess.Popen:
    return subprocess.Popen(
        [sys.executable, "-m", "flexhrc", "demo", "table", "--log", str(log), *extra],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=subprocess_env(),
    )


def _wait_for_events(log: Path, proc: subprocess.Popen, n: int, timeout: float = 60.0) -> None:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if log.exists() and len(log.read_text().splitlines()) >= n:
            return
        assert proc.poll() is None, proc.communicate()
        time.sleep(0.05)
    proc.kill()
    pytest.fail(f"fewer than {n} events in {log} after {timeout} s")


@pytest.mark.slow
def test_sigkill_leaves_a_readable_log_that_replay_says_was_cut_short(tmp_path, capsys):
    """Acceptance (issue 9, item 2): SIGKILL during `demo table --log run.jsonl --realtime 10`."""
    log = tmp_path / "run.jsonl"
    proc = _start(log, "--realtime", "10")
    _wait_for_events(log, proc, 60)  # mid-run, well before the end (about 150 events)
    proc.send_signal(signal.SIGKILL)
    proc.communicate(timeout=30)
    assert proc.returncode == -signal.SIGKILL
    text = log.read_text()
    written = [json.loads(line) for line in text.splitlines()]  # every line is whole
    assert text.endswith("\n") and len(written) >= 30
    assert not any(e["type"] in ("outcome", "summary") for e in written)
    assert main(["replay", str(log), "--json"]) == 0
    captured = capsys.readouterr()
    data = json.loads(captured.out)
    assert data["events"] == len(written)  # every event written before the kill is read
    assert data["outcome"] == "cut_short" and not data["complete"]
    assert data["compute_recorded"] is False  # no closing summary: Table I says n/a, not 0
    assert "the run was cut short" in captured.err
    assert data["decisions"] == sum(e["type"] == "decision" for e in written) >= 1


def test_every_argument_of_these_commands_has_help():
    import argparse

    from flexhrc.cli import build_parser

    missing = []

    def walk(parser: argparse.ArgumentParser, path: list[str]) -> None:
        for action in parser._actions:
            if isinstance(action, argparse._SubParsersAction):
                for name, sub in action.choices.items():
                    walk(sub, [*path, name])
            elif action.help is None and path[:1] in (
                ["demo"],
                ["run"],
                ["replay"],
                ["sim"],
                ["har"],
                ["scene"],
            ):
                missing.append(f"{' '.join(path)} {'/'.join(action.option_strings) or action.dest}")

    walk(build_parser(), [])
    assert missing == []


def test_help_of_the_package_points_at_an_architecture_page_that_exists():
    import flexhrc

    from ..conftest import REPO

    assert "docs/architecture.md" in (flexhrc.__doc__ or "")
    text = (REPO / "docs" / "architecture.md").read_text()
    for package in ("logic", "representation", "knowledge", "taskmanager", "action", "cli"):
        assert f"`{package}`" in text


@pytest.mark.slow
@pytest.mark.parametrize(("sig", "code"), [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
def test_sigint_and_sigterm_write_a_final_event(tmp_path, sig, code, capsys):  # A6
    log = tmp_path / "run.jsonl"
    proc = _start(log, "--realtime", "10", "--simulator", "analytic", "--json", "--quiet")
    _wait_for_events(log, proc, 20)
    proc.send_signal(sig)
    out, err = proc.communicate(timeout=30)
    assert proc.returncode == code, err
    assert "Traceback" not in err and "interrupted" in err
    events = [json.loads(line) for line in log.read_text().splitlines()]
    assert [e["type"] for e in events[-2:]] == ["outcome", "summary"]
    assert events[-2]["outcome"] == "interrupted"
    assert events[-2]["reason"] == f"interrupted by {signal.Signals(sig).name}"
    assert json.loads(out)["outcome"] == "interrupted"  # the summary is still printed
    assert main(["replay", str(log), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["outcome"] == "interrupted"


def test_a_read_only_folder_is_refused_before_the_run(tmp_path):  # B8: --plot rodir/t.png
    rodir = tmp_path / "rodir"
    rodir.mkdir()
    rodir.chmod(0o555)
    proc = unprivileged(["demo", "table", *FAST, "--plot", str(rodir / "t.png")])
    assert proc.returncode == 2 and "Traceback" not in proc.stderr
    assert proc.stderr.strip() == (
        f"error: --plot {rodir / 't.png'}: cannot write in {rodir}: Permission denied"
    )
    assert proc.stdout == ""  # refused before the run: no trace, no table


def test_replay_of_a_behaviour_log_points_at_behave_replay(tmp_path, capsys):
    from flexhrc.cli import main

    log = tmp_path / "b.jsonl"
    assert main(["behave", "(THEN a b)", "--log", str(log)]) == 0
    capsys.readouterr()
    assert main(["replay", str(log)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [
        f"error: {log}:1: a behaviour network's log: read it with 'flexhrc behave replay'"
    ]
