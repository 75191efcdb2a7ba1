//! What the end-to-end tests share: a synthetic drive rendered and opened as a sequence.

use roadvo_sim::kitti::{Sequence, read_poses};
use roadvo_sim::mount::MountFile;
use roadvo_sim::run::mount_for;
use roadvo_sim::scenario::Scenario;
use roadvo_sim::simulate::{poses_path, sequence_dir, simulate};

/// The first `frames` of `scenario` (`seed`, `overlays` on top) rendered into `dir`: the
/// sequence, its truth, and the mount file beside it.
pub fn render(
    dir: &std::path::Path,
    scenario: &str,
    overlays: &[&str],
    frames: usize,
    seed: u64,
) -> (Sequence, Vec<[f64; 12]>, MountFile) {
    let overlays: Vec<String> = overlays.iter().map(|o| o.to_string()).collect();
    let sc = Scenario::load(scenario, &overlays).unwrap();
    simulate(&sc, dir, seed, Some(frames), &()).unwrap();
    let seq = Sequence::open(&sequence_dir(dir)).unwrap();
    let truth = read_poses(&poses_path(dir)).unwrap();
    let mount = mount_for(&seq, None).unwrap();
    (seq, truth, mount)
}
