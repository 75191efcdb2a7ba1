//! The heading where the whole image sees nothing but road (`weigh_road_heading`), end to end on
//! the kitti-like drive with suspension: the image's heading weighed with the ground vote's own
//! by their running disagreements against the image's alone.

use roadvo::Method;
use roadvo_sim::eval::evaluate_planar;
use roadvo_sim::kitti::Sequence;
use roadvo_sim::mount::MountFile;
use roadvo_sim::run::{RunOutput, run_sequence};

mod common;

/// Frames of the drive: about 260 m, its first two bends.
const FRAMES: usize = 300;

/// A run of `seq` with `mount`, `weigh_road_heading` as given.
fn run(seq: &Sequence, mount: &MountFile, weigh: bool) -> RunOutput {
    let mut mount = *mount;
    mount.settings.weigh_road_heading = weigh;
    run_sequence(seq, &mount, Some(Method::PitchVote)).unwrap()
}

#[test]
fn on_road_alone_the_weighed_heading_drifts_less_than_the_images() {
    let dir = tempfile::tempdir().unwrap();
    let (seq, truth, mount) = common::render(dir.path(), "kitti-like", &["suspension"], FRAMES);
    let (weighed, image) = (run(&seq, &mount, true), run(&seq, &mount, false));
    // Until the hat has frames the image's heading stands, and the ground's second vote leaves
    // the first's observations as they were: the two runs' estimates agree bit for bit.
    let first = |r: &RunOutput| r.estimates[..10].to_vec();
    assert_eq!(first(&weighed), first(&image));
    assert_ne!(weighed.estimates, image.estimates);
    let r = |r: &RunOutput| {
        let planar = evaluate_planar(&truth, &r.poses).unwrap();
        planar.r_err_deg_per_m.unwrap()
    };
    let (w, i) = (r(&weighed), r(&image));
    assert!(
        w < 0.6 * i,
        "r_err in the ground plane: weighed {w:.4}, the image's {i:.4} deg/m"
    );
    assert!(
        w <= 0.005,
        "r_err in the ground plane: weighed {w:.4} deg/m"
    );
}
