"""An independent estimate of each frame's heading change, to tell the odometer's error from the
ground truth's: OpenCV's corners (up to 2,000 a frame), pyramidal Lucas-Kanade with a
forward-backward check, the five-point RANSAC and a robust Sampson refinement of its motion
(SciPy). Nothing of roadvo's is used but the mount file, through which the heading change is
read as the vehicle's turn about its own vertical (as scripts/heading-errors reads the truth).

Usage: heading_reference.py SEQ_DIR POSES MOUNT QUALITY_JSONL
Prints one line: frames, the reference against the truth (rms, mean), the odometer's run
(its quality lines) against the truth and against the reference, degrees a frame."""
import json
import math
import os
import sys

import cv2
import numpy as np
from scipy.optimize import least_squares
from scipy.spatial.transform import Rotation

sys.path.insert(0, os.path.dirname(__file__))
from run_truth import true_turn, vehicle_from_camera, vehicle_turn  # noqa: E402

CORNERS = 2000
LK = dict(winSize=(21, 21), maxLevel=3)
ROUND_TRIP_PX = 0.5
RANSAC_PX = 0.5


def intrinsics(seq):
    for line in open(os.path.join(seq, "calib.txt")):
        if line.startswith("P0:"):
            return np.array(list(map(float, line.split()[1:]))).reshape(3, 4)[:, :3]
    sys.exit(f"{seq}/calib.txt: no P0 line")


def skew(t):
    return np.array([[0, -t[2], t[1]], [t[2], 0, -t[0]], [-t[1], t[0], 0]])


def motion(p):
    """Rotation (a rotation vector) and the translation's direction (two angles) of `p`."""
    r = Rotation.from_rotvec(p[:3]).as_matrix()
    t = np.array([math.cos(p[4]) * math.sin(p[3]), math.sin(p[4]), math.cos(p[4]) * math.cos(p[3])])
    return r, t


def sampson_px(p, x1, x2, focal):
    r, t = motion(p)
    e = skew(t) @ r
    ex1, etx2 = x1 @ e.T, x2 @ e
    num = np.sum(x2 * ex1, 1)
    return focal * num / np.sqrt(ex1[:, 0] ** 2 + ex1[:, 1] ** 2 + etx2[:, 0] ** 2 + etx2[:, 1] ** 2)


def camera_rotation(a, b, k):
    """The second camera's axes in the first's, from frames `a` and `b`; None where too few
    corners are tracked."""
    p0 = cv2.goodFeaturesToTrack(a, CORNERS, 0.01, 8)
    if p0 is None or len(p0) < 8:
        return None
    p1, st, _ = cv2.calcOpticalFlowPyrLK(a, b, p0, None, **LK)
    back, st2, _ = cv2.calcOpticalFlowPyrLK(b, a, p1, None, **LK)
    ok = (st[:, 0] == 1) & (st2[:, 0] == 1) & (np.linalg.norm((back - p0)[:, 0], axis=1) < ROUND_TRIP_PX)
    u1, u2 = p0[ok, 0], p1[ok, 0]
    if len(u1) < 8:
        return None
    e, mask = cv2.findEssentialMat(u1, u2, k, cv2.RANSAC, 0.999, RANSAC_PX)
    if e is None or e.shape != (3, 3):
        return None
    _, r, t, mask = cv2.recoverPose(e, u1, u2, k, mask=mask)
    inl = mask[:, 0] > 0
    ki = np.linalg.inv(k)
    x1 = np.c_[u1, np.ones(len(u1))] @ ki.T
    x2 = np.c_[u2, np.ones(len(u2))] @ ki.T
    t = t[:, 0]
    start = np.r_[Rotation.from_matrix(r).as_rotvec(), math.atan2(t[0], t[2]), math.asin(t[1])]
    fit = least_squares(lambda p: sampson_px(p, x1[inl], x2[inl], k[0, 0]), start,
                        loss="cauchy", f_scale=0.5)
    # x2 = R x1 + t: the second camera's axes in the first's are R's transpose.
    return motion(fit.x)[0].T


def stats(errors):
    e = np.degrees(np.array(errors))
    return math.sqrt(float(np.mean(e * e))), float(np.mean(e))


def main():
    if len(sys.argv) != 5:
        sys.exit(__doc__)
    seq, poses, mount, quality_path = sys.argv[1:]
    cv2.setRNGSeed(0)
    k = intrinsics(seq)
    truth = [list(map(float, line.split())) for line in open(poses)]
    quality = [json.loads(line) for line in open(quality_path)]
    m = vehicle_from_camera(mount)
    images = sorted(f for f in os.listdir(os.path.join(seq, "image_0")) if f.endswith(".png"))
    n = min(len(images), len(truth), len(quality))
    read = lambda i: cv2.imread(os.path.join(seq, "image_0", images[i]), cv2.IMREAD_GRAYSCALE)
    ref_truth, odo_truth, odo_ref = [], [], []
    last = read(0)
    for i in range(1, n):
        this = read(i)
        rotation = camera_rotation(last, this, k)
        last = this
        turn = true_turn(truth, i, m)
        odometer = quality[i]["heading_change_rad"]
        odo_truth.append(odometer - turn)
        if rotation is not None:
            reference = vehicle_turn(rotation.tolist(), m)
            ref_truth.append(reference - turn)
            odo_ref.append(odometer - reference)
    print("%6d %8d %9.4f %9.4f %9.4f %9.4f %9.4f %9.4f" % (
        n - 1, len(ref_truth), *stats(ref_truth), *stats(odo_truth), *stats(odo_ref)))


main()
