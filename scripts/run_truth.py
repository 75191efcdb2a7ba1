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


def _rot(axis, a):
    c, s = math.cos(a), math.sin(a)
    return {"x": [[1, 0, 0], [0, c, -s], [0, s, c]], "y": [[c, 0, s], [0, 1, 0], [-s, 0, c]],
            "z": [[c, -s, 0], [s, c, 0], [0, 0, 1]]}[axis]


def mul(a, b):
    """The product of two 3x3 matrices (lists of rows)."""
    return [[sum(a[i][k] * b[k][j] for k in range(3)) for j in range(3)] for i in range(3)]


def transpose(a):
    return [list(r) for r in zip(*a)]


def vehicle_from_camera(mount_file):
    """The camera-to-vehicle rotation of a mount file, body level, as the core builds it
    (Mount::rotation_vehicle_from_camera)."""
    import tomllib
    m = tomllib.load(open(mount_file, "rb")).get("mount", {})
    yaw, pitch, roll = (math.radians(m.get(k, 0.0)) for k in ("yaw_deg", "pitch_deg", "roll_deg"))
    axes = [[0, 0, 1], [-1, 0, 0], [0, -1, 0]]
    return mul(mul(mul(_rot("z", yaw), _rot("y", -pitch)), _rot("x", roll)), axes)


def vehicle_turn(camera_rotation, m):
    """The vehicle's turn about its own vertical (radians, left positive) of a camera rotation
    between two frames (the second camera's axes in the first's), seen through the mount's
    camera-to-vehicle rotation `m`: for a camera pitched down, the turn of its optical axis in
    its own plane is not the vehicle's."""
    q = mul(mul(m, camera_rotation), transpose(m))
    return math.atan2(q[1][0], q[0][0])


def true_turn(truth, i, m):
    """The truth's vehicle turn from frame i - 1 to frame i (`vehicle_turn` of its camera
    poses)."""
    r = lambda p: [p[0:3], p[4:7], p[8:11]]
    return vehicle_turn(mul(transpose(r(truth[i - 1])), r(truth[i])), m)


def drawn(truth, min_steps=4):
    """The frames i (the step from frame i - 1) where the ground truth is drawn rather than
    measured: a run of `min_steps` or more steps along which its track holds its direction,
    each step within 1e-3 deg of the one before, while its heading turns by 0.01 deg or more a
    frame. A measured track at a metre a step holds its direction that closely for two steps
    by chance now and then (KITTI 02, 06 and 07 once each), never for four; a turning heading
    over a straight track is a fill-in between fixes (KITTI 06's first 11 frames: a straight
    line, the heading ramped at 0.039 deg a frame), with no turn to compare an estimate
    against. A rendered drive's straight stretches do not turn, so none of its frames is
    drawn."""
    def track(i):
        return math.degrees(math.atan2(truth[i][3] - truth[i - 1][3], truth[i][11] - truth[i - 1][11]))

    out, run = set(), []
    for i in range(1, len(truth) + 1):
        if i < len(truth) and run and abs(track(i) - track(run[-1])) < 1e-3:
            run.append(i)
            continue
        if len(run) >= min_steps:
            out.update(j for j in run if abs(math.degrees(true_motion(truth, j)[0])) >= 0.01)
        run = [i]
    return out
