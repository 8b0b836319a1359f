import subprocess
import sys

import flexhrc
from flexhrc.cli import build_parser, main

from .conftest import subprocess_env


def test_version_and_light_import():
    assert flexhrc.__version__
    # The core import must stay light: no heavy optional dependency gets pulled in.
    code = (
        "import sys, flexhrc, flexhrc.cli; "
        "heavy = [m for m in ('matplotlib', 'pinocchio', 'pybullet', 'sklearn', 'zenoh', 'scipy')"
        " if m in sys.modules]; print(','.join(heavy))"
    )
    out = subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True,
        text=True,
        check=True,
        env=subprocess_env(),
    )
    assert out.stdout.strip() == ""


def test_cli_without_command_prints_help(capsys):
    assert main([]) == 2
    assert "usage" in capsys.readouterr().err


def test_parser_builds():
    assert build_parser().prog == "flexhrc"
