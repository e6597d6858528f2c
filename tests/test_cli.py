"""The fepre command: version, help, benchmark listing, user-facing errors."""

from __future__ import annotations

import subprocess
import sys

import fepre
from fepre.cli import main


def test_version_flag_prints_the_package_version(capsys):
    try:
        main(["--version"])
    except SystemExit as exit_:
        assert exit_.code == 0
    assert capsys.readouterr().out.strip() == f"fepre {fepre.__version__}"


def test_no_command_prints_help_and_exits_2(capsys):
    assert main([]) == 2
    assert "COMMAND" in capsys.readouterr().out


def test_bench_list_names_the_sdf_benchmark(capsys):
    assert main(["bench", "--list"]) == 0
    assert "sdf" in capsys.readouterr().out.split()


def test_unknown_benchmark_is_a_user_error(capsys):
    assert main(["bench", "no-such-benchmark"]) == 1
    err = capsys.readouterr().err
    assert "unknown benchmark 'no-such-benchmark'" in err and "Traceback" not in err


def test_console_script_runs_as_a_module():
    result = subprocess.run([sys.executable, "-m", "fepre", "--version"], capture_output=True, text=True)
    assert result.returncode == 0 and result.stdout.startswith("fepre ")
