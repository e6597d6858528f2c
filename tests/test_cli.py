"""The fepre command: version, help, benchmark listing, user-facing errors."""

from __future__ import annotations

import subprocess
import sys

import pytest

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


def test_bench_scale_checks_its_arguments(capsys):
    from fepre.bench import scale

    with pytest.raises(SystemExit):
        scale.main(["--cells", "10"])
    assert "--cells must be a number of cells of at least 1000; got 10" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        scale.main(["--repeat", "0"])
    assert "--repeat must be at least 1; got 0" in capsys.readouterr().err


def test_bench_scale_parts_have_their_volumes():
    """The benchmark's parts are what their descriptions say: Monte Carlo volumes against the
    analytic ones."""
    import math

    import numpy as np

    from fepre.bench.scale import _model

    expected = {
        "box-holes": 100 * 80 * 20 - 20 * math.pi * 16 * 20,
        "flange": math.pi * (50**2 * 10 + 20**2 * 20 - 10**2 * 30 - 6 * 4**2 * 10),
    }
    rng = np.random.default_rng(0)
    for name, volume in expected.items():
        model = _model(name)
        lower, upper = (np.asarray(b, float) for b in model.bounds)
        samples = rng.uniform(lower, upper, (400_000, 3))
        measured = float((model(samples) < 0).mean() * np.prod(upper - lower))
        assert measured == pytest.approx(volume, rel=0.01), name


def test_unknown_option_prints_the_subcommand_usage(capsys, tmp_path):
    """``fepre mesh part.py --bogus`` is a mistake in the mesh command's options: its usage, not
    the top-level one, and the option named."""
    with pytest.raises(SystemExit) as exit_:
        main(["mesh", str(tmp_path / "part.py"), "-o", str(tmp_path / "x.vtu"), "--bogus"])
    assert exit_.value.code == 2
    err = capsys.readouterr().err
    assert err.startswith("usage: fepre mesh "), err
    assert "--bogus" in err and "fepre mesh: error:" in err


def test_every_option_has_help_text():
    """--seed had none: every option of every command says what it does."""
    from fepre.cli import build_parser

    parser = build_parser()
    missing = []
    for action in parser._subparsers._group_actions:
        for name, sub in action.choices.items():
            for option in sub._actions:
                if option.option_strings and not option.help:
                    missing.append(f"{name} {option.option_strings[-1]}")
    assert not missing, missing


def test_benchmark_descriptions_speak_in_user_terms(capsys):
    """``bench --list`` and the DistMeshOptions docs spoke of "the seed's chapter-4 experiments",
    "seed Tables 1-2" and "the issue's models": project history, not what the benchmark does."""
    import re

    assert main(["bench", "--list"]) == 0
    listing = capsys.readouterr().out
    jargon = re.compile(r"\bseed's|\bseed tables|tables 1-2|\bissue\b|issue's|chapter-4", re.IGNORECASE)
    assert not jargon.findall(listing), listing
    assert not jargon.findall(fepre.DistMeshOptions.__doc__)


def test_unknown_option_before_the_command_is_the_top_level_usage(capsys, tmp_path):
    with pytest.raises(SystemExit) as exit_:
        main(["--bogus", "mesh", str(tmp_path / "part.py"), "-o", str(tmp_path / "x.vtu")])
    assert exit_.value.code == 2
    err = capsys.readouterr().err
    assert err.startswith("usage: fepre [-h]") and "--bogus" in err, err
