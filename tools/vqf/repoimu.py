"""VQF on the RepoIMU recordings, as ../shared/data/repoimu/README.md scores it.

Prints, per file and as the mean of the 6: VQF 2.1 online (`VQF(dt).updateBatch`), and VQF
online with its bias estimate started at the gyro's mean over the recording's last 3 s (the
pendulum hangs still there: the rest bias), the same metric as `host-tests`'s real-data table
(inclination RMSE; heading RMSE with its circular mean removed). Run by `scripts/vqf-reference`.

Then the mean inclination of VQF's accelerometer low-pass alone (motion bias estimation off)
with its time constant at 1 s and at 3 s (its default): how the recording's gyro errors grow
over a longer average.

Then, per file, the constant gyro bias that best explains the whole recording: the gyro
integrated from the first true attitude, with the bias fitted by least squares (Gauss-Newton)
to the optical truth, beside the rest bias. Where the two differ on the vertical x axis, no
bias estimate that is right at rest can hold the heading during the swings.
"""
import glob
import os
import sys

import numpy as np
from vqf import VQF


def qmul(a, b):
    w1, x1, y1, z1 = a.T
    w2, x2, y2, z2 = b.T
    return np.stack([w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
                     w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                     w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
                     w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2], 1)


def score(q_est, q_true):
    """(inclination, heading) RMSE in degrees, the README's metric."""
    c = q_true.copy()
    c[:, 1:] *= -1
    e = qmul(q_est, c)
    inc = 2 * np.arctan2(np.hypot(e[:, 1], e[:, 2]), np.hypot(e[:, 0], e[:, 3]))
    h = 2 * np.arctan2(e[:, 3], e[:, 0])
    m = np.arctan2(np.sin(h).mean(), np.cos(h).mean())
    h = (h - m + np.pi) % (2 * np.pi) - np.pi
    return np.degrees(np.sqrt((inc ** 2).mean())), np.degrees(np.sqrt((h ** 2).mean()))


def rotation_matrices(q):
    w, x, y, z = q.T
    return np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
        np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
        np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1)], 1)


def integrate(q0, gyr, dt, bias):
    """Body rates less `bias`, integrated from q0 (exact rotation per step, held rate)."""
    q = np.empty((len(gyr), 4))
    q[0] = q0
    for k in range(1, len(gyr)):
        w = (gyr[k - 1] - bias) * dt[k - 1]
        a = np.linalg.norm(w)
        v = w * (np.sin(a / 2) / a) if a > 1e-12 else w / 2
        q[k] = qmul(q[k - 1][None], np.array([[np.cos(a / 2), *v]]))[0]
        q[k] /= np.linalg.norm(q[k])
    return q


def best_constant_bias(t, gyr, q_true, iterations=3):
    """Constant bias (rad/s) minimising the attitude error of gyro integration against truth.

    The error angle (NED) at row k depends on the bias through -∫ R dt up to k: linear least
    squares on that Jacobian, iterated."""
    dt = np.diff(t)
    bias = np.zeros(3)
    for _ in range(iterations):
        q = integrate(q_true[0], gyr, dt, bias)
        c = q_true.copy()
        c[:, 1:] *= -1
        e = qmul(q, c)
        e *= np.sign(e[:, :1])
        err = 2 * e[:, 1:]
        jac = np.zeros((len(t), 3, 3))
        jac[1:] = -np.cumsum(rotation_matrices(q)[:-1] * dt[:, None, None], 0)
        m = np.einsum("kij,kil->jl", jac, jac)
        v = np.einsum("kij,ki->j", jac, err)
        bias = bias - np.linalg.solve(m, v)
    return bias


def load(path):
    """A trace's time, median step, gyro and accelerometer (C-contiguous, as VQF wants them),
    truth, and the rotation that turns VQF's z-up output into body→NED: (0, 1, 0, 0) ⊗ q."""
    d = np.genfromtxt(path, delimiter=",", names=True, comments="#")
    t = d["t"]
    dt = float(np.median(np.diff(t)))
    gyr = np.ascontiguousarray(np.stack([d["gx"], d["gy"], d["gz"]], 1))
    acc = np.ascontiguousarray(np.stack([d["ax"], d["ay"], d["az"]], 1))
    q_true = np.stack([d["qw"], d["qx"], d["qy"], d["qz"]], 1)
    to_ned = np.tile([0.0, 1.0, 0.0, 0.0], (len(t), 1))
    return t, dt, gyr, acc, q_true, to_ned


def one_trace(path):
    """VQF online on any trace with truth (e.g. the `handheld` example's): started at zero bias,
    at the mean gyro over the first 9 s (a still start), and the same with its motion bias
    estimation off (its accelerometer low-pass alone; the simulator's bias is constant)."""
    t, dt, gyr, acc, q_true, to_ned = load(path)
    plain = score(qmul(to_ned, VQF(dt).updateBatch(gyr, acc)["quat6D"]), q_true)
    b0 = gyr[t < t[0] + 9.0].mean(0)
    v = VQF(dt)
    v.setBiasEstimate(b0, np.radians(0.03))
    started = score(qmul(to_ned, v.updateBatch(gyr, acc)["quat6D"]), q_true)
    v = VQF(dt, motionBiasEstEnabled=False)
    v.setBiasEstimate(b0, np.radians(0.03))
    lp_only = score(qmul(to_ned, v.updateBatch(gyr, acc)["quat6D"]), q_true)
    print(f"{os.path.basename(path)}: VQF online {plain[0]:.2f} / {plain[1]:.2f}, "
          f"bias started from the first 9 s {started[0]:.2f} / {started[1]:.2f}, "
          f"the same without motion bias estimation {lp_only[0]:.2f} / {lp_only[1]:.2f} "
          "(inclination / heading RMSE, deg)")


def main():
    if len(sys.argv) == 3 and sys.argv[1] == "--trace":
        return one_trace(sys.argv[2])
    data = sys.argv[1] if len(sys.argv) > 1 else os.path.join(
        os.path.dirname(__file__), "..", "..", "..", "shared", "data", "repoimu")
    files = sorted(glob.glob(os.path.join(data, "*.csv")))
    if not files:
        sys.exit(f"vqf-reference: no RepoIMU CSV files in {data}")
    rows = []
    fits = []
    lp_only = {1.0: [], 3.0: []}
    print(f"{'file':40} {'VQF online':>16} {'VQF, rest bias':>16}   rest bias (deg/s)")
    for f in files:
        t, dt, gyr, acc, q_true, to_ned = load(f)
        plain = score(qmul(to_ned, VQF(dt).updateBatch(gyr, acc)["quat6D"]), q_true)
        rest_bias = gyr[t > t[-1] - 3.0].mean(0)
        v = VQF(dt)
        v.setBiasEstimate(rest_bias, np.radians(0.03))
        started = score(qmul(to_ned, v.updateBatch(gyr, acc)["quat6D"]), q_true)
        rows.append(plain + started)
        for tau, scores in lp_only.items():
            q = VQF(dt, tauAcc=tau, motionBiasEstEnabled=False).updateBatch(gyr, acc)["quat6D"]
            scores.append(score(qmul(to_ned, q), q_true)[0])
        fits.append((os.path.basename(f), rest_bias, best_constant_bias(t, gyr, q_true)))
        print(f"{os.path.basename(f):40} {plain[0]:6.2f} / {plain[1]:6.2f}  {started[0]:6.2f} / "
              f"{started[1]:6.2f}   {np.degrees(rest_bias).round(3)}")
    m = np.mean(rows, 0)
    print(f"{'mean':40} {m[0]:6.2f} / {m[1]:6.2f}  {m[2]:6.2f} / {m[3]:6.2f}")
    print("VQF's accelerometer low-pass alone (motion bias estimation off), mean inclination: "
          + ", ".join(f"tauAcc {tau:g} s {np.mean(s):.2f}" for tau, s in lp_only.items()))
    print()
    print(f"{'file':40} {'rest bias x y z (deg/s)':>24}   {'best constant bias x y z':>24}")
    for name, rest, best in fits:
        r, b = np.degrees(rest), np.degrees(best)
        print(f"{name:40} {r[0]:7.3f} {r[1]:7.3f} {r[2]:7.3f}   {b[0]:7.3f} {b[1]:7.3f} {b[2]:7.3f}")


if __name__ == "__main__":
    main()
