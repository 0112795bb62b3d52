"""``sim2real robots new`` / ``robots check`` through the CLI; the written file works as --robot."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from sim2real.cli import main


def _run(capsys: pytest.CaptureFixture[str], *argv: object) -> tuple[int, str, str]:
    try:
        code = main([str(a) for a in argv])
    except SystemExit as exc:  # argparse usage errors
        code = int(exc.code or 0)
    out, err = capsys.readouterr()
    return code, out, err


def test_new_then_check(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "neato.yaml"
    code, text, _ = _run(
        capsys, "robots", "new", "neato", "--wheel-separation", 0.248, "--max-speed", 0.3, "-o", out
    )
    assert code == 0 and "checks passed (6)" in text
    assert yaml.safe_load(out.read_text())["limits"]["max_v_mps"] == 0.3
    code, text, _ = _run(capsys, "robots", "check", out)
    assert code == 0 and text.count("ok  ") == 6 and "all 6 checks passed" in text
    code, text, _ = _run(capsys, "robots", "show", out)
    assert code == 0 and "separation 0.248 m" in text
    # an existing file is not overwritten without --force
    code, _, err = _run(capsys, "robots", "new", "neato", "--wheel-separation", 0.3, "-o", out)
    assert code == 2 and "exists; pass --force" in err
    assert yaml.safe_load(out.read_text())["wheels"]["separation_m"] == 0.248


def test_new_with_every_option_small_robot(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # a small light robot: its wheel spin inertia (0.5 * 0.075 kg * 0.04^2 = 6e-05 kg m^2) was
    # written as `6e-05`, which YAML 1.1 reads as a string, so the written spec did not load
    out = tmp_path / "mouse.yaml"
    code, text, err = _run(
        capsys, "robots", "new", "mouse", "--wheel-separation", 0.3, "--wheel-radius", 0.04,
        "--mass", 2.5, "--max-speed", 0.5, "--max-turn-rate", 2.5, "--footprint-radius", 0.2,
        "--drive", "diff", "--driver-track-factor", 1.0, "-o", out,
    )  # fmt: skip
    assert code == 0 and "checks passed (6)" in text, err
    doc = yaml.safe_load(out.read_text())
    assert doc["wheels"]["spin_inertia_kgm2"] == pytest.approx(6e-05, rel=1e-6)
    assert doc["wheels"]["radius_m"] == 0.04 and doc["wheels"]["separation_m"] == 0.3
    assert doc["limits"]["max_v_mps"] == 0.5 and doc["limits"]["max_w_radps"] == 2.5
    code, text, _ = _run(capsys, "robots", "show", out)
    assert code == 0 and "rigid mass:     2.5000 kg" in text and "separation 0.3 m" in text


def test_check_refuses_a_bad_spec(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "r.yaml"
    assert _run(capsys, "robots", "new", "r", "--wheel-separation", 0.3, "-o", out)[0] == 0
    doc = yaml.safe_load(out.read_text())
    doc["base"]["body"]["xyz_m"] = [0.0, 0.0, -0.05]
    out.write_text(yaml.safe_dump(doc))
    code, text, err = _run(capsys, "robots", "check", out)
    assert code == 2 and "FAIL  body clear of the ground" in text
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "fails the check 'body clear of the ground'" in lines[0]


@pytest.mark.parametrize(
    ("argv", "match"),
    [
        (["--wheel-separation", "0"], "wheel_separation_m must be a finite number > 0"),
        (["--wheel-separation", "0.3", "--footprint-radius", "0.05"], "wheels would stick out"),
        ([], "the following arguments are required: --wheel-separation"),
    ],
)
def test_new_bad_input(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], argv: list[str], match: str
) -> None:
    code, _, err = _run(capsys, "robots", "new", "r", *argv, "-o", tmp_path / "r.yaml")
    assert code == 2 and match in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "r.yaml").exists()


def test_unknown_robot_did_you_mean(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code, _, err = _run(capsys, "robots", "check", "turtlebot2_")
    assert code == 2 and "did you mean 'turtlebot2'" in err


@pytest.mark.parametrize(("drive", "corners"), [("diff", 0), ("skid", 4)])
def test_skids_of_a_skid_steer_stand_at_the_footprint_corners(
    drive: str, corners: int, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from robots.spec import load_spec

    out = tmp_path / "base.yaml"
    argv = ["--wheel-separation", 1.08, "--wheel-radius", 0.3, "--drive", drive]
    code, text, _ = _run(capsys, "robots", "new", "base", *argv, "-o", out)
    assert code == 0 and "checks passed (6)" in text
    spec = load_spec(out)
    radius = yaml.safe_load(out.read_text())["base"]["body"]["radius_m"]
    xy = [(c.xyz_m[0], c.xyz_m[1]) for c in spec.casters]
    # a skid steer's other wheels stand at the corners: off the centre line on both sides,
    # so a hard turn-and-reverse cannot roll the base onto one skid; a diff drive keeps its
    # casters front and back on the centre line
    off_line = [p for p in xy if abs(p[1]) > 0.25 * radius]
    assert len(off_line) == corners and len(xy) == (4 if drive == "skid" else 2)
    assert all(abs(x) > 0.25 * radius and x * x + y * y < radius * radius for x, y in off_line)
    if drive == "skid":
        assert {(x > 0, y > 0) for x, y in xy} == {
            (a, b) for a in (True, False) for b in (True, False)
        }
