"""Files through Python: measurements round trip, robots from files, and bad input raising
FileFormatError with the file, line and column."""

import numpy as np
import pytest

import kincal
from conftest import UR10E_URDF, need


def sample(robot, count=5, seed=3):
    rng = np.random.default_rng(seed)
    lim = np.clip(robot.joint_limits, -np.pi, np.pi)
    q = lim[:, 0] + rng.random((count, robot.n_joints)) * (lim[:, 1] - lim[:, 0])
    return q, robot.fk(q)


def test_measurements_round_trip_bit_for_bit(tmp_path):
    robot = kincal.aria()
    q, poses = sample(robot)
    m = kincal.Measurements.from_arrays(q, poses, pose_ids=[f"p{i}" for i in range(len(q))])
    path = tmp_path / "m.csv"
    m.write(path)
    back = kincal.read_measurements(path, robot, require_pose=True)
    assert len(back) == len(q)
    assert np.array_equal(back.q, q)
    assert np.array_equal(back.position_m, poses[:, :3, 3])
    assert np.abs(back.poses - poses).max() < 1e-15
    assert back.pose_ids == [f"p{i}" for i in range(len(q))]
    assert back.lines == [2, 3, 4, 5, 6]
    assert len(back.sha256) == 64


def test_millimetre_and_degree_columns_arrive_in_si(tmp_path):
    path = tmp_path / "mm.csv"
    path.write_text("q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg,x_mm,y_mm,z_mm\n"
                    "10,20,30,40,50,60,100,200,300\n")
    m = kincal.read_measurements(path, kincal.aria())
    assert np.allclose(m.q[0], np.radians([10, 20, 30, 40, 50, 60]), rtol=0, atol=1e-15)
    assert np.array_equal(m.position_m[0], [0.1, 0.2, 0.3])
    assert np.isnan(m.poses[0]).all()  # no orientation measured


def test_bad_csv_cell_names_file_line_and_column(tmp_path):
    path = tmp_path / "bad.csv"
    path.write_text("q1,q2,q3,q4,q5,q6,x,y,z\n"
                    "0,0,0,0,0,0,0.1,0.2,0.3\n"
                    "0,0,0,zero,0,0,0.1,0.2,0.3\n")
    with pytest.raises(kincal.FileFormatError) as err:
        kincal.read_measurements(path, kincal.aria())
    e = err.value
    assert isinstance(e, kincal.KincalError)
    assert (e.path, e.line, e.field) == (str(path), 3, "q4")
    assert f"{path}:3" in str(e)


def test_wrong_joint_count_is_a_file_format_error(tmp_path):
    path = tmp_path / "five.csv"
    path.write_text("q1,q2,q3,q4,q5,x,y,z\n0,0,0,0,0,0.1,0.2,0.3\n")
    with pytest.raises(kincal.FileFormatError) as err:
        kincal.read_measurements(path, kincal.aria())
    assert err.value.path == str(path) and err.value.line == 1


def test_bad_robot_description_names_line_and_column(tmp_path):
    path = tmp_path / "robot.toml"
    path.write_text('name = "two"\n\n[[joint]]\nd_mm = "ten"\n')
    with pytest.raises(kincal.FileFormatError) as err:
        kincal.load_robot(path)
    e = err.value
    assert e.path == str(path)
    assert e.line == 4 and e.column is not None and e.column >= 1, str(e)


def test_missing_file_and_unknown_link(tmp_path):
    # Neither a built-in name nor a file: a bad argument, as on the command line (exit 2).
    with pytest.raises(kincal.UsageError, match="none.toml"):
        kincal.load_robot(tmp_path / "none.toml")
    need(UR10E_URDF.is_file(), "UR10e URDF missing")
    with pytest.raises(kincal.KincalError, match="no_such_link"):
        kincal.load_robot(UR10E_URDF, base_link="base_link", tip_link="no_such_link")


def test_model_file_round_trip(tmp_path):
    robot = kincal.aria()
    path = tmp_path / "aria.json"
    robot.save(path)
    again = kincal.load_robot(path)
    assert again.n_joints == 6
    assert np.array_equal(again.params, robot.params)
    assert again.model_file()["schema_version"] == robot.model_file()["schema_version"]
