"""calibrate through Python gives the command line's model file, number for number, on the
paper's simulation study (ARIA's Table 3 truth measured with noise), and recovers the truth."""

import json

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
def study(tmp_path_factory):
    """40 poses of the virtual truth, measured with 0.1 mm / 0.02° noise (seeded)."""
    rng = np.random.default_rng(7)
    truth = kincal.aria("virtual_truth")
    lim = np.clip(truth.joint_limits, -np.pi, np.pi)
    q = lim[:, 0] + rng.random((40, 6)) * (lim[:, 1] - lim[:, 0])
    poses = truth.fk(q)
    for t in poses:
        t[:3, 3] += rng.normal(0.0, SIGMA_POS_M, 3)
        t[:3, :3] = rotation(rng.normal(0.0, SIGMA_ROT_RAD, 3)) @ t[:3, :3]
    path = tmp_path_factory.mktemp("study") / "calibration_noisy.csv"
    kincal.Measurements.from_arrays(q, poses).write(path)
    return path, truth


@pytest.mark.parametrize("flags, kwargs", [
    (["--algorithm", "all", "--bounds-deg", "60"], dict(algorithm="all", bounds_deg=60)),
    (["--robust", "huber", "--sigma-pos-mm", "0.1", "--sigma-rot-deg", "0.02"],
     dict(robust="huber", sigma_pos_mm=0.1, sigma_rot_deg=0.02)),
])
def test_python_gives_the_cli_model_file(study, kincal_bin, tmp_path, flags, kwargs):
    path, _ = study
    out = tmp_path / "cli.json"
    done = run_cli(kincal_bin, "calibrate", str(path), "--robot", "aria", *flags, "--out", str(out))
    assert done.returncode == 0, done.stderr
    model = kincal.calibrate(str(path), kincal.aria(), **kwargs)
    mine = tmp_path / "py.json"
    model.save(mine)
    # Model files carry no run time: the same inputs give the same bytes.
    assert mine.read_bytes() == out.read_bytes()
    assert model.model_file() == json.loads(out.read_text())


def test_a_failed_algorithm_is_a_warning_and_recorded(kincal_bin, tmp_path):
    """algorithm="all" with too few iterations for OPT1 or OPT2 but enough for OLS (on the
    demo's noise-free calibration-tool poses, where OLS converges in 5 iterations and OPT1
    needs more): the model is OLS's, each failure a UserWarning and a `calibration.failed`
    entry, the model file the command line's byte for byte."""
    r = run_cli(kincal_bin, "demo", "--out", str(tmp_path / "demo"))
    assert r.returncode == 0, r.stderr
    path = tmp_path / "demo" / "calibration_noise_free.csv"
    for k in range(3, 15):
        out = tmp_path / f"cli{k}.json"
        done = run_cli(kincal_bin, "calibrate", str(path), "--robot", "aria", "--algorithm",
                       "all", "--bounds-deg", "60", "--max-iterations", str(k), "--out", str(out))
        if done.returncode == 0 and " failed: " in done.stderr:
            break
    else:
        pytest.fail("no iteration limit between 3 and 14 fails OPT1 or OPT2 but not OLS")
    with pytest.warns(UserWarning, match=r"OPT[12] failed: .*no convergence") as caught:
        model = kincal.calibrate(str(path), kincal.aria(), algorithm="all", bounds_deg=60,
                                 max_iterations=k)
    cal = model.model_file()["calibration"]
    assert cal["algorithm"] == "ols"
    assert [f["algorithm"] for f in cal["failed"]] == [
        str(w.message)[:4].strip().lower() for w in caught if "failed" in str(w.message)]
    mine = tmp_path / "py.json"
    model.save(mine)
    assert mine.read_bytes() == out.read_bytes()


def test_calibration_recovers_the_truth(study):
    path, truth = study
    model = kincal.calibrate(path, kincal.aria(), algorithm="opt2")
    # Held-out poses: the calibrated model's errors against the truth stay at noise level,
    # the nominal model's are millimetres.
    rng = np.random.default_rng(99)
    lim = np.clip(truth.joint_limits, -np.pi, np.pi)
    q = lim[:, 0] + rng.random((50, 6)) * (lim[:, 1] - lim[:, 0])
    err_cal = np.linalg.norm(model.fk(q)[:, :3, 3] - truth.fk(q)[:, :3, 3], axis=1)
    err_nom = np.linalg.norm(kincal.aria().fk(q)[:, :3, 3] - truth.fk(q)[:, :3, 3], axis=1)
    assert err_cal.max() < 0.2e-3, err_cal.max()
    assert err_nom.max() > 5e-3, err_nom.max()
    cal = model.model_file()["calibration"]
    assert cal["algorithm"] == "opt2"


def test_calibrate_arguments_and_data_errors(study, tmp_path):
    path, _ = study
    with pytest.raises(ValueError, match="algorithm"):
        kincal.calibrate(path, kincal.aria(), algorithm="newton")
    with pytest.raises(kincal.UsageError, match="sigma"):
        kincal.calibrate(path, kincal.aria(), sigma_pos_mm=0.1)
    with pytest.raises(kincal.UsageError, match="effect"):
        kincal.calibrate(path, kincal.aria(), effects=["gravity_magic"])
    few = tmp_path / "few.csv"
    lines = path.read_text().splitlines()
    few.write_text("\n".join(lines[:4]) + "\n")
    with pytest.raises(kincal.NumericError, match="data-deficient: "):
        kincal.calibrate(few, kincal.aria())


def test_a_deficiency_found_at_the_fit_is_named(kincal_bin, tmp_path):
    """ARIA's ten calibration-tool poses (the demo's data) hold the flange's x axis along the
    base's x: the base's x and link 6's a are told apart only while the model is off. The
    refusal names the pair and where it was found; allowed, the model file says so."""
    r = run_cli(kincal_bin, "demo", "--out", str(tmp_path / "out"))
    assert r.returncode == 0, r.stderr
    data = tmp_path / "out" / "calibration_noise_free.csv"
    with pytest.raises(kincal.NumericError,
                       match=r"data-deficient: base_px \(aligned with a_6, at the fitted model\)"):
        kincal.calibrate(data, kincal.aria(), effects=["base_frame"])
    model = kincal.calibrate(data, kincal.aria(), effects=["base_frame"],
                             allow_data_deficiency=True)
    deficient = model.model_file()["calibration"]["identifiability"]["data_deficient"]
    assert deficient == [{"label": "base_px", "aligned_with": "a_6", "cosine": 1.0,
                          "found_at_fit": True}]


def test_pose_errors_are_the_cli_validate_figures(study, kincal_bin, tmp_path):
    path, _ = study
    model = tmp_path / "model.json"
    kincal.calibrate(path, kincal.aria(), algorithm="ols").save(model)
    report = tmp_path / "validate.json"
    done = run_cli(kincal_bin, "validate", str(model), str(path), "--json", str(report), "--quiet")
    assert done.returncode == 0, done.stderr
    cli = json.loads(report.read_text())["poses"]
    mine = kincal.load_robot(model).pose_errors(path)
    assert len(cli) == len(mine["pos_norm_m"]) == 40
    assert np.array_equal(mine["pos_m"], [p["e_pos_m"] for p in cli])
    assert np.array_equal(mine["rot_rad"], [p["e_rot_rad"] for p in cli])
    assert np.array_equal(mine["pos_norm_m"], [p["e_pos_norm_m"] for p in cli])
    # Noise-level errors, 0.1 mm per axis: the norms are a few tenths of a millimetre.
    assert 0.05e-3 < np.sqrt(np.mean(mine["pos_norm_m"] ** 2)) < 0.3e-3
