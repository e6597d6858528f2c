"""`fepre bench surface` runs end to end on small grids and prints every row."""

from __future__ import annotations

from fepre.bench import surface


def test_bench_prints_all_tables(capsys):
    assert surface.main(["--size", "40", "--band-size", "48", "--repeat", "1"]) == 0
    text = capsys.readouterr().out
    for row in ("Tables 1 and 2 of Kelly's project", "MC on the pre-sampled array", "NS on the pre-sampled array",
                "sample + FE end to end", "banded sampling", "nodes evaluated"):
        assert row in text
    assert text.count("FE (VTK)") == 3  # two seed-table rows and the large-grid row
