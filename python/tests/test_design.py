"""Pose selection, tool design and design evaluation through Python give the command line's
files and numbers exactly: `kincal select-poses --out`, `kincal design-tool --json/--out` and
`kincal evaluate-designs --json` (with socket plates too), with small settings (the debug CLI
runs them in seconds)."""

import json

import numpy as np
import pytest

import kincal
from conftest import run_cli
from test_studies import assert_same

SELECT = ["--pool", "200", "--starts", "2", "--refine", "10", "--robust-robots", "4",
          "--compare-random", "50", "-m", "8"]
SELECT_KW = dict(pool=200, starts=2, refine=10, robust_robots=4, compare_random=50, m=8)
TOOL = ["--plate-z-mm", "285", "--screen-runs", "20", "--runs", "40", "--starts", "2",
        "--robust-robots", "4", "--grid-mm", "50", "--objectives", "pv01,dopt"]
TOOL_KW = dict(plate_z_mm=[285.0], screen_runs=20, runs=40, starts=2, robust_robots=4,
               grid_mm=50.0, objectives=["pv01", "dopt"])


def fk_all(robot, q):
    return np.array([robot.fk(row) for row in q])


@pytest.mark.parametrize("design", ["standard", "region", "clustering"])
def test_select_poses_writes_the_cli_file(kincal_bin, tmp_path, design):
    cli_csv, py_csv = tmp_path / "cli.csv", tmp_path / "py.csv"
    done = run_cli(kincal_bin, "select-poses", "--design", design, *SELECT,
                   "--out", str(cli_csv))
    assert done.returncode == 0, done.stderr
    robot = kincal.aria()
    sel = kincal.select_poses(robot, design=design, out=str(py_csv), **SELECT_KW)
    assert py_csv.read_bytes() == cli_csv.read_bytes()
    assert sel["q"].shape == (8, 6) and sel["poses"].shape == (8, 4, 4)
    # The file's joint columns are the returned configurations.
    rows = np.loadtxt(cli_csv, delimiter=",", skiprows=1, usecols=range(1, 7), ndmin=2)
    np.testing.assert_allclose(rows, sel["q"], rtol=0, atol=1e-12)
    # Independently: the poses are the nominal robot's FK at the configurations.
    np.testing.assert_allclose(fk_all(robot, sel["q"]), sel["poses"], rtol=0, atol=1e-12)
    assert len(sel["random_indices"]["o"]) == 50
    assert sel["pool_size"] >= 8
    if design != "clustering":
        # The exchange maximises O: it beats the median random set of the same pool.
        assert sel["indices"]["o"] > np.median(sel["random_indices"]["o"])


def test_design_tool_is_the_cli_json(kincal_bin, tmp_path):
    cli_json, cli_csv, py_csv = tmp_path / "t.json", tmp_path / "cli.csv", tmp_path / "py.csv"
    done = run_cli(kincal_bin, "design-tool", *TOOL, "--json", str(cli_json),
                   "--out", str(cli_csv))
    assert done.returncode == 0, done.stderr
    robot = kincal.aria()
    mine = kincal.design_tool(robot, out=str(py_csv), **TOOL_KW)
    tool = mine.pop("tool")
    plates = mine.pop("plate_sockets")
    assert_same(mine, json.loads(cli_json.read_text()), rel=0.0)
    assert py_csv.read_bytes() == cli_csv.read_bytes()
    assert [z for z, _ in plates] == [pytest.approx(0.285, abs=1e-15)]
    # Sockets on the plate, reached by the returned configurations (nominal FK).
    assert tool["poses"].shape == (10, 4, 4)
    np.testing.assert_allclose(tool["poses"][:, 2, 3], 0.285, rtol=0, atol=1e-12)
    np.testing.assert_allclose(fk_all(robot, tool["q"]), tool["poses"], rtol=0, atol=1e-9)


def test_evaluate_designs_is_the_cli_json(kincal_bin, tmp_path):
    tool_csv, cli_json = tmp_path / "tool.csv", tmp_path / "e.json"
    done = run_cli(kincal_bin, "design-tool", *TOOL, "--out", str(tool_csv))
    assert done.returncode == 0, done.stderr
    done = run_cli(kincal_bin, "evaluate-designs", "--designs", "standard,table2",
                   "--tool", f"mine={tool_csv}", "--runs", "30", *SELECT[:-4],
                   "--json", str(cli_json))
    assert done.returncode == 0, done.stderr
    mine = kincal.evaluate_designs(kincal.aria(), designs=["standard", "table2"],
                                   tools=[("mine", str(tool_csv))], runs=30, pool=200,
                                   starts=2, refine=10, robust_robots=4)
    cli = json.loads(cli_json.read_text())
    assert_same(mine, cli, rel=0.0)
    assert [d["name"] for d in mine["designs"]] == ["standard", "table2", "mine"]
    assert mine["calibrations"] == 90


def test_evaluate_designs_with_plates_is_the_cli_json(kincal_bin, tmp_path):
    cli_json = tmp_path / "p.json"
    done = run_cli(kincal_bin, "evaluate-designs", "--designs", "table2", "--runs", "6",
                   "--robust-robots", "4", "--plate", "p200=200,2,16", "--json", str(cli_json))
    assert done.returncode == 0, done.stderr
    mine = kincal.evaluate_designs(kincal.aria(), designs=["table2"], runs=6, robust_robots=4,
                                   plates=[("p200", 200.0, 2, 16)])
    assert_same(mine, json.loads(cli_json.read_text()), rel=0.0)
    tool, plate = mine["plates"]
    assert (tool["kind"], plate["kind"]) == ("known-pose tool", "socket plate")
    assert (plate["contacts"], plate["placements"], plate["distance_mm"]) == (16, 2, 200.0)
    # Independently: the plates' tool row is the study's table2 calibration on the same
    # robots (another code path), so its absolute figures are the study's.
    study = mine["designs"][0]["worst_pose_e_p_mm"]
    for k in ("median", "p95", "max"):
        assert tool["absolute_worst_pose_e_p_mm"][k] == pytest.approx(study[k], rel=1e-12)
    # A plate cannot see the base frame: absolute errors of millimetres, registered ones
    # a fraction of them.
    reg = plate["registered_worst_pose_e_p_mm"]["median"]
    assert plate["absolute_worst_pose_e_p_mm"]["median"] > 10 * reg


def test_bad_plates_raise():
    robot = kincal.aria()
    with pytest.raises(kincal.UsageError, match=r"plates\[0\].*fewer than 2"):
        kincal.evaluate_designs(robot, designs=["table2"], plates=[("x", 50.0, 3, 11)])
    with pytest.raises(kincal.UsageError, match="D_MM must be a positive number"):
        kincal.evaluate_designs(robot, designs=["table2"], plates=[("x", -5.0, 1, 10)])
    with pytest.raises(kincal.UsageError, match="plates: two designs are named 'table2'"):
        kincal.evaluate_designs(robot, designs=["table2"], runs=2, robust_robots=2,
                                plates=[("table2", 50.0, 1, 10)])


def test_bad_design_arguments_raise(tmp_path):
    robot = kincal.aria()
    with pytest.raises(kincal.UsageError, match="design"):
        kincal.select_poses(robot, design="nope")
    with pytest.raises(kincal.UsageError, match="m: expected 1..=48"):
        kincal.select_poses(robot, m=0)
    with pytest.raises(kincal.UsageError, match="workspace"):
        kincal.select_poses(robot, workspace=(0, 0, 0, -1, 1, 1))
    with pytest.raises(kincal.UsageError, match="index"):
        kincal.select_poses(robot, index="best")
    with pytest.raises(kincal.UsageError, match="objective"):
        kincal.design_tool(robot, objectives=["fast"])
    with pytest.raises(kincal.UsageError, match="runs"):
        kincal.design_tool(robot, runs=0)
    with pytest.raises(kincal.UsageError, match="plate-z-mm|outside"):
        kincal.design_tool(robot, plate_z_mm=[900.0], **{k: v for k, v in TOOL_KW.items()
                                                          if k != "plate_z_mm"})
    with pytest.raises(kincal.UsageError, match="design"):
        kincal.evaluate_designs(robot, designs=["mystery"])
    bad = tmp_path / "bad-tool.csv"
    bad.write_text("pose_id,x_mm,y_mm,z_mm,roll_deg,pitch_deg,yaw_deg\n1,466,316,abc,-160,0,90\n")
    with pytest.raises(kincal.FileFormatError) as err:
        kincal.design_tool(robot, baseline=("bad", str(bad)), **TOOL_KW)
    assert err.value.path == str(bad) and err.value.line == 2
