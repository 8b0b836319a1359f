"""Input reading, output-path checks, atomic writes and streamed, locked logs."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

from flexhrc.errors import FormatError
from flexhrc.files import (
    EventLogWriter,
    OutputPathError,
    atomic_output,
    atomic_write_text,
    check_output,
    read_text,
)


def test_read_text_reports_binary_non_utf8_folder_missing(tmp_path):
    (tmp_path / "bin").write_bytes(b"ab\x00cd")
    (tmp_path / "latin").write_bytes(b"ok\n\xcaf\n")
    with pytest.raises(FormatError, match="binary data"):
        read_text(tmp_path / "bin")
    with pytest.raises(FormatError, match=r"latin:2: not UTF-8 text \(byte 0xca\)"):
        read_text(tmp_path / "latin")
    with pytest.raises(FormatError, match="is a folder"):
        read_text(tmp_path)
    with pytest.raises(FormatError, match="no such file"):
        read_text(tmp_path / "none")
    (tmp_path / "bom").write_bytes("\ufeffhello".encode())
    assert read_text(tmp_path / "bom") == "hello"


def test_check_output_refuses_bad_paths_and_creates_nothing(tmp_path):
    with pytest.raises(OutputPathError, match=r"--log .*does not exist"):
        check_output(tmp_path / "no" / "x.jsonl", option="--log")
    assert not (tmp_path / "no").exists()
    with pytest.raises(OutputPathError, match="is a folder"):
        check_output(tmp_path, option="-o")
    with pytest.raises(OutputPathError, match="not a regular file"):
        check_output("/dev/null", option="-o")
    with pytest.raises(OutputPathError, match=r"unsupported output format '\.xyz'"):
        check_output(tmp_path / "a.xyz", option="--plot", suffixes={".png", ".svg"})
    src = tmp_path / "in.txt"
    src.write_text("graph")
    with pytest.raises(OutputPathError, match="is an input"):
        check_output(src, option="--events", inputs=[src])
    assert src.read_text() == "graph"
    assert (
        check_output(tmp_path / "ok.png", option="--plot", suffixes={".png"}) == tmp_path / "ok.png"
    )
    assert sorted(p.name for p in tmp_path.iterdir()) == ["in.txt"]


def test_atomic_output_keeps_old_file_on_failure(tmp_path):
    target = tmp_path / "out.txt"
    atomic_write_text(target, "old")
    with pytest.raises(RuntimeError), atomic_output(target) as tmp:
        tmp.write_text("half")
        raise RuntimeError("boom")
    assert target.read_text() == "old"
    assert [p.name for p in tmp_path.iterdir()] == ["out.txt"]


def test_event_log_is_locked_and_streamed(tmp_path):
    path = tmp_path / "run.jsonl"
    with EventLogWriter(path) as log:
        log.write({"t": 0.0, "type": "start"})
        # another process sees the first line already, and cannot take the log
        code = (
            "import sys; from flexhrc.files import EventLogWriter, OutputPathError\n"
            "print(open(sys.argv[1]).read().count('\\n'))\n"
            "try:\n    EventLogWriter(sys.argv[1])\nexcept OutputPathError as e:\n    print('refused')\n"
        )
        env = dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path))
        out = subprocess.run(
            [sys.executable, "-c", code, str(path)],
            capture_output=True,
            text=True,
            env=env,
            check=True,
        ).stdout.split()
        assert out == ["1", "refused"]
        with pytest.raises(ValueError):
            log.write({"t": float("nan")})
    assert [json.loads(x)["type"] for x in path.read_text().splitlines()] == ["start"]
    with EventLogWriter(path) as log:  # free again once closed; a new run starts a new log
        log.write({"t": 1.0, "type": "start"})
    assert len(path.read_text().splitlines()) == 1
