"""FK, frames, Jacobian and IK through Python, checked against Pinocchio (an independent
implementation) and finite differences."""

import numpy as np
import pytest

import kincal
from conftest import UR10E_URDF, ci, need

try:
    import pinocchio as pin
except ImportError:
    if ci():
        raise  # CI=true: a missing tool is a failure, never a skip
    pytest.skip("pinocchio missing (pip install pin)", allow_module_level=True)

RNG = np.random.default_rng(20241)


def random_q(robot: kincal.Robot, count: int) -> np.ndarray:
    lim = np.clip(robot.joint_limits, -np.pi, np.pi)
    return lim[:, 0] + RNG.random((count, robot.n_joints)) * (lim[:, 1] - lim[:, 0])


def hayati_pinocchio_model(robot: kincal.Robot):
    """ARIA as a Pinocchio chain, built from the README's convention alone:
    A_i = Rz(q_i + θ0_i)·Tz(d_i)·Tx(a_i)·Rx(α_i)·Ry(β_i), T = T_0^b·A_1···A_N·T_e^N, and base/tool
    frames Trans(p)·Rot(r) with r a rotation vector."""
    p = dict(zip(robot.param_labels, robot.params))

    def trans_rot(prefix):
        return pin.SE3(pin.exp3(np.array([p[prefix + "_rx"], p[prefix + "_ry"], p[prefix + "_rz"]])),
                       np.array([p[prefix + "_px"], p[prefix + "_py"], p[prefix + "_pz"]]))

    def link_after_joint(i):
        tz = pin.SE3(np.eye(3), np.array([0.0, 0.0, p[f"d_{i}"]]))
        tx = pin.SE3(np.eye(3), np.array([p[f"a_{i}"], 0.0, 0.0]))
        rx = pin.SE3(pin.utils.rotate("x", p[f"alpha_{i}"]), np.zeros(3))
        ry = pin.SE3(pin.utils.rotate("y", p[f"beta_{i}"]), np.zeros(3))
        return tz * tx * rx * ry

    model = pin.Model()
    parent, placement = 0, trans_rot("base")
    for i in range(1, robot.n_joints + 1):
        rz0 = pin.SE3(pin.utils.rotate("z", p[f"theta0_{i}"]), np.zeros(3))
        parent = model.addJoint(parent, pin.JointModelRZ(), placement * rz0, f"j{i}")
        placement = link_after_joint(i)
    model.addFrame(pin.Frame("tool", parent, 0, placement * trans_rot("tool"), pin.FrameType.OP_FRAME))
    return model


def test_aria_fk_matches_pinocchio_to_1e12():
    robot = kincal.aria()
    model = hayati_pinocchio_model(robot)
    data = model.createData()
    tool = model.getFrameId("tool")
    qs = random_q(robot, 200)
    ours = robot.fk(qs)
    worst = 0.0
    for q, t in zip(qs, ours):
        pin.framesForwardKinematics(model, data, q)
        worst = max(worst, np.abs(data.oMf[tool].homogeneous - t).max())
    assert worst < 1e-12, worst
    # The batch and the single call are the same numbers.
    assert np.array_equal(robot.fk(qs[0]), ours[0])


def test_ur10e_urdf_fk_matches_pinocchio_to_1e12():
    need(UR10E_URDF.is_file(), f"{UR10E_URDF} missing (../shared/realdata)")
    robot = kincal.load_robot(UR10E_URDF, base_link="base_link", tip_link="tool0")
    assert robot.n_joints == 6
    model = pin.buildModelFromUrdf(str(UR10E_URDF))
    data = model.createData()
    names = ["shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint",
             "wrist_1_joint", "wrist_2_joint", "wrist_3_joint"]
    idx_q = [model.joints[model.getJointId(n)].idx_q for n in names]
    base, tip = model.getFrameId("base_link"), model.getFrameId("tool0")
    worst = 0.0
    for q in random_q(robot, 200):
        qp = pin.neutral(model)
        qp[idx_q] = q
        pin.framesForwardKinematics(model, data, qp)
        expected = (data.oMf[base].inverse() * data.oMf[tip]).homogeneous
        worst = max(worst, np.abs(expected - robot.fk(q)).max())
    assert worst < 1e-12, worst


def test_frames_end_at_the_tool_and_start_at_the_base():
    robot = kincal.aria()
    q = random_q(robot, 1)[0]
    f = robot.frames(q)
    assert f.shape == (robot.n_joints + 2, 4, 4)
    assert np.array_equal(f[-1], robot.fk(q))
    assert np.array_equal(f[0], robot.frames(random_q(robot, 1)[0])[0])  # frame 0 does not move


def test_jacobian_matches_finite_differences():
    robot = kincal.aria()
    q = random_q(robot, 1)[0]
    jac, labels = robot.jacobian(q)
    assert jac.shape == (6, len(labels))
    values = robot.params
    index = {l: i for i, l in enumerate(robot.param_labels)}
    t0 = robot.fk(q)
    h = 1e-7
    for c, label in enumerate(labels):
        # Central differences of position and of the rotation error log(R·R0ᵀ).
        plus = values.copy(); plus[index[label]] += h
        minus = values.copy(); minus[index[label]] -= h
        tp, tm = robot.with_params(plus).fk(q), robot.with_params(minus).fk(q)
        dp = (tp[:3, 3] - tm[:3, 3]) / (2 * h)
        dphi = (pin.log3(tp[:3, :3] @ t0[:3, :3].T) - pin.log3(tm[:3, :3] @ t0[:3, :3].T)) / (2 * h)
        assert np.allclose(jac[:3, c], dp, atol=1e-6), label
        assert np.allclose(jac[3:, c], dphi, atol=1e-6), label


def test_ik_returns_to_the_pose():
    robot = kincal.aria()
    q = random_q(robot, 1)[0]
    target = robot.fk(q)
    sol, res_p, res_r, _ = robot.ik(target)
    assert res_p < 1e-9 and res_r < 1e-9
    assert np.abs(robot.fk(sol) - target).max() < 1e-9


def test_bad_arguments_raise_value_errors():
    robot = kincal.aria()
    with pytest.raises(ValueError, match="expected 6"):
        robot.fk([0.0, 0.0])
    with pytest.raises(kincal.UsageError):
        robot.fk([np.nan] * 6)
    with pytest.raises(kincal.UsageError, match="orthonormal"):
        robot.ik(np.diag([2.0, 1.0, 1.0, 1.0]))
