"""What scripts/turns and scripts/roll-heading share: a run's per-frame quality and the sequence's
ground truth, read from the command line, and the truth's motion between two frames."""
import json
import math
import sys


def load(usage):
    """The run's quality lines and the ground-truth poses named by argv; exits with `usage` or
    a message naming the file when they do not fit."""
    if len(sys.argv) != 3:
        sys.exit(usage)
    quality = [json.loads(line) for line in open(sys.argv[1])]
    truth = [list(map(float, line.split())) for line in open(sys.argv[2])]
    if len(truth) < len(quality):
        sys.exit(f"{sys.argv[2]}: {len(truth)} poses for {len(quality)} frames")
    return quality, truth


def heading(p):
    # Camera 0's optical axis (z) in the ground plane: its x and z components.
    return math.atan2(p[2], p[10])


def true_motion(truth, i):
    """The truth's heading change (radians, left positive, as the odometer's) and ground-plane
    distance (metres) from frame i - 1 to frame i."""
    turn = -(heading(truth[i]) - heading(truth[i - 1]))
    turn = (turn + math.pi) % (2 * math.pi) - math.pi
    step = math.dist((truth[i][3], truth[i][11]), (truth[i - 1][3], truth[i - 1][11]))
    return turn, step
