"""crossval and diagnose through Python give the command line's reports: crossval's dict is
`kincal crossval --json`'s document, diagnose's is REPORT.json's (without `files`), number
for number; bad input raises the right exception with the file's line and column."""

import json
import math

import numpy as np
import pytest

import kincal
from conftest import run_cli

SIGMA_POS_M = 0.1e-3
SIGMA_ROT_RAD = np.radians(0.02)


def rotation(v):
    """Rodrigues' formula (independent of kincal)."""
    angle = np.linalg.norm(v)
    if angle == 0.0:
        return np.eye(3)
    k = v / angle
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K


@pytest.fixture(scope="module")
def session(tmp_path_factory):
    """30 poses of ARIA's virtual truth, each measured twice (pose_id repeats: a noise
    floor) with 0.1 mm / 0.02° noise (seeded)."""
    rng = np.random.default_rng(11)
    truth = kincal.aria("virtual_truth")
    lim = np.clip(truth.joint_limits, -np.pi, np.pi)
    q = lim[:, 0] + rng.random((30, 6)) * (lim[:, 1] - lim[:, 0])
    q = np.repeat(q, 2, axis=0)
    poses = truth.fk(q)
    for t in poses:
        t[:3, 3] += rng.normal(0.0, SIGMA_POS_M, 3)
        t[:3, :3] = rotation(rng.normal(0.0, SIGMA_ROT_RAD, 3)) @ t[:3, :3]
    ids = [f"p{i // 2}" for i in range(len(q))]
    path = tmp_path_factory.mktemp("session") / "session.csv"
    kincal.Measurements.from_arrays(q, poses, pose_ids=ids).write(path)
    return path


def assert_same(mine, cli, where="", rel=1e-12):
    """Equal structure; numbers equal to `rel` (relative), everything else exactly."""
    if isinstance(cli, dict):
        assert isinstance(mine, dict) and mine.keys() == cli.keys(), where
        for k in cli:
            assert_same(mine[k], cli[k], f"{where}.{k}", rel)
    elif isinstance(cli, list):
        assert isinstance(mine, list) and len(mine) == len(cli), where
        for i, (a, b) in enumerate(zip(mine, cli)):
            assert_same(a, b, f"{where}[{i}]", rel)
    elif isinstance(cli, float) and not isinstance(cli, bool):
        assert isinstance(mine, (int, float)), where
        assert math.isclose(mine, cli, rel_tol=rel, abs_tol=1e-300), f"{where}: {mine} != {cli}"
    else:
        assert mine == cli, f"{where}: {mine!r} != {cli!r}"


@pytest.mark.parametrize("flags, kwargs", [
    ([], {}),
    (["--folds", "4", "--seed", "9", "--sigma-pos-mm", "0.1", "--sigma-rot-deg", "0.02",
      "--effects", "base_frame,tool_frame", "--robust", "huber"],
     dict(folds=4, seed=9, sigma_pos_mm=0.1, sigma_rot_deg=0.02,
          effects=["base_frame", "tool_frame"], robust="huber")),
    (["--unit-weights", "--geometry", "d,a"], dict(unit_weights=True, geometry=["d", "a"])),
])
def test_crossval_is_the_cli_json(session, kincal_bin, tmp_path, flags, kwargs):
    out = tmp_path / "cv.json"
    done = run_cli(kincal_bin, "crossval", str(session), "--robot", "aria", *flags,
                   "--json", str(out))
    assert done.returncode == 0, done.stderr
    cli = json.loads(out.read_text())
    mine = kincal.crossval(str(session), kincal.aria(), **kwargs)
    assert_same(mine, cli, rel=0.0)
    # The held-out figures, independently: RMS of the per-pose norms.
    cal = np.array([p["calibrated_pos_mm"] for p in mine["poses"]])
    assert math.isclose(mine["heldout"]["calibrated"]["rms_pos_mm"],
                        np.sqrt(np.mean(cal ** 2)), rel_tol=1e-9)
    if not kwargs:
        # The full geometry calibrates the truth's errors away: held-out near the noise
        # (√3·0.1 mm), the nominal model's millimetres.
        assert mine["heldout"]["calibrated"]["rms_pos_mm"] < 0.5
    assert mine["heldout"]["nominal"]["rms_pos_mm"] > 2.0


def test_crossval_prior_auto(session, kincal_bin, tmp_path):
    out = tmp_path / "cv.json"
    done = run_cli(kincal_bin, "crossval", str(session), "--robot", "aria",
                   "--prior", "auto", "--json", str(out))
    assert done.returncode == 0, done.stderr
    mine = kincal.crossval(session, kincal.aria(), prior="auto")
    assert_same(mine, json.loads(out.read_text()), rel=0.0)
    assert len(mine["prior"]["grid"]) == 7


def test_diagnose_is_the_cli_report(session, kincal_bin, tmp_path):
    report = tmp_path / "out" / "REPORT.json"
    report.parent.mkdir()
    done = run_cli(kincal_bin, "diagnose", str(session), "--robot", "aria",
                   "--candidates", "joint_scale,joint_compliance",
                   "--json", str(report), "--out", str(tmp_path / "out" / "model.json"))
    assert done.returncode == 0, done.stderr
    cli = json.loads(report.read_text())
    mine = kincal.diagnose(str(session), kincal.aria(),
                           candidates=["joint_scale", "joint_compliance"])
    assert "files" not in mine
    del cli["files"]
    assert_same(mine, cli)
    # ARIA's virtual truth differs from the nominal in geometry only: no effect explains
    # more than the noise, and the noise floor comes from the repeats (≈ 0.1 mm per axis).
    assert mine["verdict"]["status"] in ("no_gap", "unexplained"), mine["verdict"]
    assert mine["noise_floor"]["pos_source"] == "repeats"
    assert 0.05 < mine["noise_floor"]["pos_mm"] < 0.2


def test_bad_input_raises_with_line_and_column(session, tmp_path):
    bad = tmp_path / "bad.csv"
    lines = session.read_text().splitlines()
    header = lines[0].split(",")
    row = lines[3].split(",")
    row[header.index("q3")] = "three"
    lines[3] = ",".join(row)
    bad.write_text("\n".join(lines) + "\n")
    for study in (kincal.crossval, kincal.diagnose):
        with pytest.raises(kincal.FileFormatError) as err:
            study(bad, kincal.aria())
        e = err.value
        assert (e.path, e.line, e.field) == (str(bad), 4, "q3"), str(e)


def test_bad_arguments_raise_usage_errors(session, tmp_path):
    aria = kincal.aria()
    with pytest.raises(kincal.UsageError, match="folds"):
        kincal.crossval(session, aria, folds=1)
    with pytest.raises(kincal.UsageError, match="effect"):
        kincal.crossval(session, aria, effects=["gravity_magic"])
    with pytest.raises(kincal.UsageError, match="sigma"):
        kincal.crossval(session, aria, sigma_pos_mm=0.1)
    with pytest.raises(kincal.UsageError, match="fewer than"):
        kincal.crossval(session, aria, folds=31)
    with pytest.raises(kincal.UsageError, match="folds"):
        kincal.diagnose(session, aria, folds=1)
    # No repeats and no stated noise: no noise floor, named as Python spells the arguments.
    single = tmp_path / "single.csv"
    lines = session.read_text().splitlines()
    single.write_text("\n".join(lines[:1] + lines[1::2]) + "\n")
    with pytest.raises(kincal.UsageError, match="sigma_pos_mm"):
        kincal.diagnose(single, aria)
