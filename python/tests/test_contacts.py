"""crossval and diagnose of contact (target/plane) data through Python give the command
line's reports number for number: `kincal crossval --constraints --json`'s document and the
contact REPORT.json of `kincal diagnose --constraints`. The data: MuKCa's panda_2_clean
(../shared/realdata/mukca), imported by the CLI."""

import json

import pytest

import kincal
from conftest import REALDATA, need, run_cli
from test_studies import assert_same

ID = "panda_2_clean"


@pytest.fixture(scope="module")
def mukca(kincal_bin, tmp_path_factory):
    """(csv, robot TOML, constraints TOML) of panda_2_clean: 520 contacts, 8 sessions."""
    src = REALDATA / "mukca"
    need(src.is_dir(), f"{src} is missing")
    out = tmp_path_factory.mktemp("mukca")
    csv, toml, cons = out / f"{ID}.csv", out / f"{ID}.toml", out / f"{ID}-constraints.toml"
    done = run_cli(kincal_bin, "import-dataset", "mukca", str(src), "--robot-id", ID,
                   "--out", str(csv), "--robot-out", str(toml), "--constraints-out", str(cons))
    assert done.returncode == 0, done.stderr
    return csv, toml, cons


def common(mukca):
    csv, toml, cons = mukca
    return [str(csv), "--robot", str(toml), "--constraints", str(cons), "--allow-out-of-limits"]


@pytest.mark.parametrize("flags, kwargs", [
    ([], {}),
    (["--group-by", "target", "--folds", "3", "--seed", "7", "--robust", "cauchy",
      "--sigma-pos-mm", "0.2", "--sigma-rot-deg", "0.1"],
     dict(group_by="target", folds=3, seed=7, robust="cauchy", sigma_pos_mm=0.2,
          sigma_rot_deg=0.1)),
])
def test_contact_crossval_is_the_cli_json(mukca, kincal_bin, tmp_path, flags, kwargs):
    out = tmp_path / "cv.json"
    done = run_cli(kincal_bin, "crossval", *common(mukca), *flags, "--json", str(out))
    assert done.returncode == 0, done.stderr
    cli = json.loads(out.read_text())
    csv, toml, cons = mukca
    mine = kincal.crossval(str(csv), kincal.load_robot(str(toml)), constraints=str(cons),
                           allow_out_of_limits=True, **kwargs)
    assert_same(mine, cli, rel=0.0)
    # Independently of the report's own totals: every group is held out in exactly one
    # fold, and the calibrated model beats the nominal one held out on real data.
    held = [label for fold in mine["folds"] for label in fold["held_out"]]
    assert len(held) == len(set(held))
    assert mine["group_by"] == kwargs.get("group_by", "session")
    assert mine["held_out"]["calibrated"]["rms_mm"] < mine["held_out"]["nominal"]["rms_mm"]


def test_contact_diagnose_is_the_cli_report(mukca, kincal_bin, tmp_path):
    out = tmp_path / "d.json"
    done = run_cli(kincal_bin, "diagnose", *common(mukca), "--sigma-pos-mm", "0.17",
                   "--no-pairs", "--json", str(out), "--out", str(tmp_path / "unused.json"))
    assert done.returncode == 0, done.stderr
    cli = json.loads(out.read_text())
    csv, toml, cons = mukca
    mine = kincal.diagnose(str(csv), kincal.load_robot(str(toml)), constraints=str(cons),
                           sigma_pos_mm=0.17, pairs=False, allow_out_of_limits=True)
    assert_same(mine, cli, rel=0.0)
    assert mine["method"] == "leave_one_group_out_contacts"
    # The geometric model first; single effects only.
    assert mine["candidates"][0]["effects"] == []
    assert all(len(c["effects"]) == 1 for c in mine["candidates"][1:])


def test_contact_arguments_raise_usage_errors(mukca):
    csv, toml, cons = mukca
    robot = kincal.load_robot(str(toml))
    with pytest.raises(kincal.UsageError, match="group_by"):
        kincal.crossval(str(csv), robot, constraints=str(cons), group_by="tool",
                        allow_out_of_limits=True)
    with pytest.raises(kincal.UsageError, match="init_frames"):
        kincal.crossval(str(csv), robot, constraints=str(cons), init_frames=True,
                        allow_out_of_limits=True)
    with pytest.raises(kincal.UsageError, match="base_frame"):
        kincal.diagnose(str(csv), robot, constraints=str(cons), candidates=["base_frame"],
                        allow_out_of_limits=True)
