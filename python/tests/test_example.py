"""The worked example of docs/python.md: the page shows exactly the script, and it runs."""

from __future__ import annotations

import csv
import runpy

from conftest import CORNELL, ROOT

SCRIPT = ROOT / "python" / "examples" / "spp_sweep.py"


def test_the_docs_show_the_script():
    page = (ROOT / "docs" / "python.md").read_text()
    assert "```python\n" + SCRIPT.read_text() + "```" in page


def test_the_sweep_runs_and_its_error_falls_with_spp(tmp_path):
    sweep = runpy.run_path(str(SCRIPT))
    rows = sweep["main"](
        [str(CORNELL), "--size", "24", "--spp", "1,4,16", "--reference-spp", "256", "--seeds", "2", "-o", str(tmp_path)]
    )
    with open(tmp_path / "spp_sweep.csv") as f:
        table = list(csv.DictReader(f))
    assert len(table) == len(rows) == 6
    assert {r["sampler"] for r in table} == {"sobol", "independent"}
    for sampler in ("sobol", "independent"):
        errors = [float(r["rmse"]) for r in table if r["sampler"] == sampler]
        # 16 times the samples: a quarter of the error expected; a 1-spp image of a tiny
        # render is heavy-tailed, so only the ends of the ladder are compared, with margin.
        assert 0 < errors[2] < errors[0] / 2, (sampler, errors)
