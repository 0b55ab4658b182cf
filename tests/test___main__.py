"""``python -m hvacflex`` runs the command line."""

import subprocess
import sys

from hvacflex.version import __version__


def test_python_dash_m_runs_the_cli() -> None:
    done = subprocess.run(
        [sys.executable, "-m", "hvacflex", "--version"], capture_output=True, text=True, check=False
    )
    assert done.returncode == 0, done.stderr
    assert __version__ in done.stdout


def test_python_dash_m_bad_option_exits_2() -> None:
    done = subprocess.run(
        [sys.executable, "-m", "hvacflex", "--no-such-option"],
        capture_output=True,
        text=True,
        check=False,
    )
    assert done.returncode == 2
    assert "Traceback" not in done.stderr


def test_importing_main_runs_nothing() -> None:
    """A stored state once named ``hvacflex.__main__``: importing it must not run the CLI."""
    done = subprocess.run(
        [sys.executable, "-c", "import hvacflex.__main__", "--version"],
        capture_output=True,
        text=True,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout == ""
