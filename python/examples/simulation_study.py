"""The paper's simulation study in a few lines of Python: measure ARIA's Table 3 "virtual
truth" at random poses with 0.1 mm / 0.02° noise, calibrate the Table 1 nominal model with
OLS, OPT1 and OPT2, and compare held-out position errors before and after.

    python examples/simulation_study.py [OUT_DIR]
"""

import sys
import tempfile
from pathlib import Path

import numpy as np

import kincal


def small_rotation(v):
    angle = np.linalg.norm(v)
    k = v / angle
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K


def main() -> None:
    out = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(tempfile.mkdtemp(prefix="kincal-"))
    out.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(7)
    truth, nominal = kincal.aria("virtual_truth"), kincal.aria()
    lim = np.clip(truth.joint_limits, -np.pi, np.pi)

    def random_q(n):
        return lim[:, 0] + rng.random((n, truth.n_joints)) * (lim[:, 1] - lim[:, 0])

    q = random_q(40)
    poses = truth.fk(q)  # (40, 4, 4), metres
    for t in poses:
        t[:3, 3] += rng.normal(0.0, 0.1e-3, 3)
        t[:3, :3] = small_rotation(rng.normal(0.0, np.radians(0.02), 3)) @ t[:3, :3]
    data = out / "calibration_noisy.csv"
    kincal.Measurements.from_arrays(q, poses).write(data)

    model = kincal.calibrate(data, nominal, algorithm="all", bounds_deg=60)
    model.save(out / "model.json")
    report = model.model_file()["calibration"]
    print(f"{len(q)} poses from {data}; identifiable parameters: "
          f"{report['identifiability']['rank']}")
    print(f"consensus of OLS, OPT1, OPT2: {report['consensus']['agree']}")

    q_test = random_q(200)
    for name, robot in [("nominal", nominal), ("calibrated", model)]:
        err = np.linalg.norm(robot.fk(q_test)[:, :3, 3] - truth.fk(q_test)[:, :3, 3], axis=1)
        print(f"{name:>10}: held-out position error RMS {1e3 * np.sqrt(np.mean(err**2)):.3f} mm, "
              f"max {1e3 * err.max():.3f} mm")
    print(f"model written to {out / 'model.json'}")


if __name__ == "__main__":
    main()
