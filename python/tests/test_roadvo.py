"""The roadvo Python package against the `roadvo` command line: the same poses bit for bit on
the shared KITTI clip, the odometer frame by frame as the unsmoothed run, and bad inputs raised
as exceptions that say what is wrong."""

import json
import math
import os
import subprocess
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

import roadvo

ROOT = Path(__file__).resolve().parents[2]
# The shared data sit beside the repository: ../shared/data/kitti.
KITTI = ROOT.parent / "shared" / "data" / "kitti"
SEQ = KITTI / "sequences" / "05"
GT = KITTI / "poses" / "05.txt"
KITTI_MOUNT = ROOT / "mounts" / "kitti.toml"

needs_kitti = pytest.mark.skipif(
    not (SEQ / "image_0").is_dir(), reason=f"no shared KITTI sequence at {SEQ}"
)

# A mount file with its own camera (KITTI 05's), for the tests that need no sequence.
MOUNT_TEXT = """
[camera]
width_px = 1226
height_px = 370
fx_px = 707.0912
fy_px = 707.0912
cx_px = 601.8873
cy_px = 183.1104

[mount]
x_m = 0.875
height_m = 1.565
pitch_deg = -1.1
"""


@pytest.fixture(scope="module")
def cli():
    """The `roadvo` command line: ROADVO_BIN where the caller has built one (scripts/test passes
    the test suite's), else built (or found built) by cargo."""
    if os.environ.get("ROADVO_BIN"):
        return str(Path(os.environ["ROADVO_BIN"]).resolve())
    out = subprocess.run(
        ["cargo", "build", "--locked", "-p", "roadvo-sim", "--bin", "roadvo",
         "--message-format=json-render-diagnostics"],
        cwd=ROOT, check=True, stdout=subprocess.PIPE, text=True,
    ).stdout
    for line in out.splitlines():
        msg = json.loads(line)
        if msg.get("reason") == "compiler-artifact" and msg["target"]["name"] == "roadvo" \
                and msg.get("executable"):
            return msg["executable"]
    raise AssertionError("cargo built no roadvo binary")


@pytest.fixture(scope="module")
def kitti_poses():
    """KITTI 05 run with mounts/kitti.toml by the package."""
    return roadvo.run(SEQ, KITTI_MOUNT)


@pytest.fixture
def mount(tmp_path):
    path = tmp_path / "mount.toml"
    path.write_text(MOUNT_TEXT)
    return roadvo.MountFile.read(path)


@needs_kitti
def test_run_writes_the_command_lines_poses_bit_for_bit(cli, kitti_poses, tmp_path):
    cli_out = tmp_path / "cli.txt"
    subprocess.run([cli, "run", str(SEQ), "--mount", str(KITTI_MOUNT), "--out", str(cli_out)],
                   check=True, stdout=subprocess.DEVNULL)
    poses = kitti_poses
    frames = len((SEQ / "times.txt").read_text().split())
    assert poses.shape == (frames, 12) and poses.dtype == np.float64
    py_out = tmp_path / "py.txt"
    roadvo.write_poses(py_out, poses)
    assert py_out.read_bytes() == cli_out.read_bytes()
    # The poses are f32 widened: the file's ten digits give each back exactly.
    assert np.array_equal(np.loadtxt(cli_out).astype(np.float32), poses.astype(np.float32))
    assert np.array_equal(roadvo.read_poses(py_out).astype(np.float32), poses.astype(np.float32))


@needs_kitti
def test_the_odometer_frame_by_frame_is_the_unsmoothed_run(tmp_path):
    mount = roadvo.MountFile.read(KITTI_MOUNT, sequence=SEQ)
    assert mount.odometer["smooth_lag_frames"] == 2
    mount.set("smooth_lag_frames=0")
    # The mount as given throughout: `run` lifts every pose through the mount learned by the
    # drive's end, the odometer frame by frame through the one learned so far.
    mount.set("learn_yaw=false")
    mount.set("learn_pitch=false")
    mount.set("learn_roll=false")
    mount.set("learn_x=false")
    mount.write(tmp_path / "mount.toml")
    poses = roadvo.run(SEQ, tmp_path / "mount.toml")

    odometer = roadvo.Odometer(mount)
    times = [float(t) for t in (SEQ / "times.txt").read_text().split()]
    camera_poses = []
    for i, t in enumerate(times):
        frame = np.asarray(Image.open(SEQ / "image_0" / f"{i:06}.png").convert("L"))
        e = odometer.process(frame, t)
        assert (e["frame"], e["time_s"], e["startup"]) == (i, t, i == 0)
        assert {k: e[k] for k in ("x_m", "y_m", "heading_rad")} == odometer.pose
        camera_poses.append(odometer.camera_pose)
    assert np.array_equal(np.array(camera_poses), poses)
    assert odometer.pose["x_m"] > 10.0, "the car drives forward"


@needs_kitti
def test_evaluate_gives_the_kitti_metric(kitti_poses):
    poses = kitti_poses
    gt = roadvo.read_poses(GT)[: len(poses)]
    report = roadvo.evaluate(gt, poses)
    assert report["frames"] == len(poses)
    assert report["path_length_m"] > 100.0
    assert 0.0 < report["short_t_err_pct"] < 100.0
    assert [row["length_m"] for row in report["short_per_length"]] == [10.0, 20.0, 30.0, 40.0, 50.0]
    # The ground truth against itself.
    assert roadvo.evaluate(gt, gt)["end_drift_pct"] == 0.0


def test_mount_file_sections_in_the_files_units(mount, tmp_path):
    assert mount.camera["width_px"] == 1226
    assert mount.mount["pitch_deg"] == -1.1
    assert mount.odometer["method"] == "pitch-vote"
    mount.set("mount.yaw_deg=-0.1")
    mount.write(tmp_path / "again.toml")
    again = roadvo.MountFile.read(tmp_path / "again.toml")
    assert again.mount == mount.mount and str(again) == str(mount)


def test_a_frame_of_the_wrong_size_is_refused_and_changes_nothing(mount):
    odometer = roadvo.Odometer(mount)
    with pytest.raises(roadvo.RoadvoError,
                       match="frame is 640x480 pixels, the configuration expects 1226x370"):
        odometer.process(np.zeros((480, 640), np.uint8), 0.0)
    e = odometer.process(np.zeros((370, 1226), np.uint8), 0.0)
    assert e["frame"] == 0 and e["startup"]
    with pytest.raises(TypeError):
        odometer.process(np.zeros((370, 1226, 3), np.uint8), 0.1)
    with pytest.raises(TypeError):
        odometer.process(np.zeros((370, 1226), np.float32), 0.1)


def test_a_time_that_does_not_increase_is_refused(mount):
    odometer = roadvo.Odometer(mount)
    frame = np.zeros((370, 1226), np.uint8)
    odometer.process(frame, 1.0)
    for t in (1.0, 0.5, 1.0000004):
        with pytest.raises(roadvo.RoadvoError, match="does not follow the previous frame's"):
            odometer.process(frame, t)
    for t in (math.nan, -1.0, math.inf):
        with pytest.raises(roadvo.RoadvoError, match="outside 0 to 1e9 s"):
            odometer.process(frame, t)
    # A column slice (not contiguous) is taken as it looks.
    wide = np.zeros((370, 2 * 1226), np.uint8)
    assert odometer.process(wide[:, ::2], 1.1)["frame"] == 1


def test_a_bad_mount_file_is_named(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text(MOUNT_TEXT.replace("height_m = 1.565", "height_m = 1.565\nwheels = 4"))
    with pytest.raises(roadvo.RoadvoError, match=r"bad\.toml[\s\S]*wheels"):
        roadvo.MountFile.read(bad)
    missing = tmp_path / "missing.toml"
    with pytest.raises(roadvo.RoadvoError, match="missing.toml"):
        roadvo.MountFile.read(missing)
    no_camera = tmp_path / "no-camera.toml"
    no_camera.write_text("[mount]\nx_m = 1.0\nheight_m = 1.5\n")
    with pytest.raises(roadvo.RoadvoError, match=r"no-camera\.toml has no \[camera\] section"):
        roadvo.MountFile.read(no_camera)
    # Read, but refused by the core: its message.
    high = tmp_path / "high.toml"
    high.write_text(MOUNT_TEXT.replace("height_m = 1.565", "height_m = -2.0"))
    with pytest.raises(roadvo.RoadvoError, match=r"above the road \(height_m > 0\)"):
        roadvo.Odometer(roadvo.MountFile.read(high))
    mount = roadvo.MountFile.read(high)
    with pytest.raises(roadvo.RoadvoError, match=r"--set wheels=4: \[odometer\] has no key `wheels`"):
        mount.set("wheels=4")


def test_bad_runs_and_poses_are_refused(tmp_path, mount):
    with pytest.raises(roadvo.RoadvoError, match="nowhere"):
        roadvo.run(tmp_path / "nowhere")
    with pytest.raises(roadvo.RoadvoError, match=r"gt_poses: expected an \(N, 12\) array"):
        roadvo.evaluate(np.zeros((3, 11)), np.zeros((3, 12)))
    eye = np.tile(np.array([1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0], float), (3, 1))
    with pytest.raises(roadvo.RoadvoError):
        roadvo.evaluate(eye, eye[:2])
    with pytest.raises(roadvo.RoadvoError, match="poses.txt"):
        roadvo.read_poses(tmp_path / "poses.txt")
    # The RoadvoError is a ValueError.
    assert issubclass(roadvo.RoadvoError, ValueError)
