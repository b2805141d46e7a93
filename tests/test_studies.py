"""The issue-10 plateau study runs end to end on a tiny budget (it leans on private optimiser hooks)."""

import re
import subprocess
import sys
from pathlib import Path

import pytest

STUDIES = Path(__file__).resolve().parents[1] / "studies"


@pytest.mark.parametrize("flags", [[], ["--true-ratio"]])
def test_plateau_study_reports_finite_medians(flags):
    output = subprocess.run([sys.executable, str(STUDIES / "plateau.py"), "1", "6", "--walk", "2", "--refit", "2",
                             *flags], capture_output=True, text=True, check=True, timeout=300).stdout
    medians = dict(re.findall(r"(\w+) (-?[\d.]+)", output.splitlines()[-1].removeprefix("median: ")))
    assert {"true", "predicted", "gradient_error", "local_error", "walk_best", "path_to_ceiling"} <= set(medians)
    assert 0.3 < float(medians["true"]) < 1.0  # 6 cycles of the 9-link seed: 55-70 % of the ceiling
    assert float(medians["path_to_ceiling"]) > 0
