"""The Neato teleop log (real) with a spec made from published numbers only (issue 12 target).

``sim2real robots new neato --wheel-separation 0.248 --max-speed 0.3`` (wheel separation and
top speed from the Neato's published figures; everything else a documented prior), the
log read as is (its spiky odometry twist is replaced by the pose's derivative, said in one
sentence), the drive fitted on the part of the log from 35 s on (forward runs, in-place turns
both ways, a long arc) and the agreement measured on the part before it (never seen by the
fit), in both engines.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from robots.spec import load_spec
from sim2real.agreement.figures import measure_agreement
from sim2real.agreement.replay import replay
from sim2real.cli import main
from sim2real.logs import read_trace
from sysid.fit import fit_drive

SPLIT_S = 35.0


@pytest.mark.realdata
@pytest.mark.slow
def test_neato_from_published_numbers(neato_log: Path, tmp_path: Path) -> None:
    spec_path = tmp_path / "neato.yaml"
    argv = ["robots", "new", "neato", "--wheel-separation", "0.248", "--max-speed", "0.3"]
    assert main([*argv, "-o", str(spec_path)]) == 0
    spec = load_spec(spec_path)
    trace = read_trace(neato_log)
    assert any("spiky" in w and "from the pose" in w for w in trace.meta.warnings)
    validate, fit_part = trace.window(0.0, SPLIT_S), trace.window(SPLIT_S, trace.duration_s + 1)
    result = fit_drive([fit_part], geometry=spec.geometry, base_params=spec.drive, robot="neato")
    for engine in ("reduced", "pybullet"):
        sim = replay(validate, robot=spec, params=result.params, engine=engine)
        report = measure_agreement(validate, sim)
        assert report.n_active > 150
        assert report.agreement >= 0.7, (engine, report.agreement)
        spec_only = measure_agreement(validate, replay(validate, robot=spec, engine=engine))
        assert report.agreement > spec_only.agreement  # the fit helps on unseen data
