"""VQF on the RepoIMU recordings, as ../shared/data/repoimu/README.md scores it.

Prints, per file and as the mean of the 6: VQF 2.1 online (`VQF(dt).updateBatch`), and VQF
online with its bias estimate started at the gyro's mean over the recording's last 3 s (the
pendulum hangs still there: the rest bias), the same metric as `host-tests`'s real-data table
(inclination RMSE; heading RMSE with its circular mean removed). Run by `scripts/vqf-reference`.
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


def main():
    data = sys.argv[1] if len(sys.argv) > 1 else os.path.join(
        os.path.dirname(__file__), "..", "..", "..", "shared", "data", "repoimu")
    files = sorted(glob.glob(os.path.join(data, "*.csv")))
    if not files:
        sys.exit(f"vqf-reference: no RepoIMU CSV files in {data}")
    rows = []
    print(f"{'file':40} {'VQF online':>16} {'VQF, rest bias':>16}   rest bias (deg/s)")
    for f in files:
        d = np.genfromtxt(f, delimiter=",", names=True)
        t = d["t"]
        dt = float(np.median(np.diff(t)))
        gyr = np.ascontiguousarray(np.stack([d["gx"], d["gy"], d["gz"]], 1))
        acc = np.ascontiguousarray(np.stack([d["ax"], d["ay"], d["az"]], 1))
        q_true = np.stack([d["qw"], d["qx"], d["qy"], d["qz"]], 1)
        # VQF's reference frame is z up: (0, 1, 0, 0) ⊗ q turns its output into body→NED.
        to_ned = np.tile([0.0, 1.0, 0.0, 0.0], (len(t), 1))
        plain = score(qmul(to_ned, VQF(dt).updateBatch(gyr, acc)["quat6D"]), q_true)
        rest_bias = gyr[t > t[-1] - 3.0].mean(0)
        v = VQF(dt)
        v.setBiasEstimate(rest_bias, np.radians(0.03))
        started = score(qmul(to_ned, v.updateBatch(gyr, acc)["quat6D"]), q_true)
        rows.append(plain + started)
        print(f"{os.path.basename(f):40} {plain[0]:6.2f} / {plain[1]:6.2f}  {started[0]:6.2f} / "
              f"{started[1]:6.2f}   {np.degrees(rest_bias).round(3)}")
    m = np.mean(rows, 0)
    print(f"{'mean':40} {m[0]:6.2f} / {m[1]:6.2f}  {m[2]:6.2f} / {m[3]:6.2f}")


if __name__ == "__main__":
    main()
