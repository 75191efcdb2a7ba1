//! `Odometer::process` on KITTI-size frames, single-threaded, frames preloaded, per method.
//! The frames are a short `kitti-like` drive with suspension motion, rendered once at start-up.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use roadvo::Method;
use roadvo::{Instant, Odometer, SliceFrame};
use roadvo_sim::kitti::Sequence;
use roadvo_sim::mount::MountFile;
use roadvo_sim::scenario::Scenario;
use roadvo_sim::simulate::{sequence_dir, simulate};
use std::hint::black_box;

/// Frames in the benchmarked drive.
const FRAMES: usize = 40;

fn process(c: &mut Criterion) {
    let dir = tempfile::tempdir().expect("temporary folder");
    let scenario = Scenario::load("kitti-like", &["suspension".into()]).expect("built-in");
    simulate(&scenario, dir.path(), 1, Some(FRAMES), &()).expect("render");
    let seq = Sequence::open(&sequence_dir(dir.path())).expect("sequence");
    let frames: Vec<_> = (0..FRAMES).map(|i| seq.load(i).expect("frame")).collect();
    let (w, h) = seq.size;
    let mut group = c.benchmark_group("process");
    group.throughput(Throughput::Elements(FRAMES as u64));
    for method in [Method::PitchVote, Method::Paper] {
        let mut mount: MountFile = scenario.mount_file(true);
        mount.settings.method = method;
        let config = mount.to_config().validate().expect("valid config");
        group.bench_function(method.name(), |b| {
            b.iter(|| {
                let mut odo: Box<Odometer> = Box::new(Odometer::new(config).expect("capacity"));
                for (i, img) in frames.iter().enumerate() {
                    let f = SliceFrame::new(img.as_raw(), w as u16, h as u16, w as usize)
                        .expect("buffer");
                    black_box(
                        odo.process(&f, Instant::from_micros(i as u64 * 100_000))
                            .expect("frame"),
                    );
                }
            })
        });
    }
    group.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(10);
    targets = process
}
criterion_main!(benches);
