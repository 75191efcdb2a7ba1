//! Host side of roadvo: everything around the core that needs `std`. Synthetic drives with exact
//! ground truth ([`scenario`], [`path`], [`render`] through [`lens_rays`], [`simulate`]), mount
//! calibration against ground truth ([`calibrate`]), the paper's sensitivity study
//! ([`sensitivity`]), the KITTI file layout ([`kitti`]), the mount file users write for their
//! vehicles ([`mount`]) and the OpenCV calibration it may name ([`opencv_calib`]), the KITTI
//! metric ([`eval`]), runs of the odometer over a sequence ([`run`]), an hour's soak of one
//! odometer ([`soak`]), plots ([`plot`]) and the firmware example's frame store
//! ([`frame_store`]). Outputs are written whole or not at all ([`output`]), and a Ctrl-C ends
//! long work cleanly ([`interrupt`]). The `roadvo` binary is a thin command line over these.

pub mod calibrate;
pub mod eval;
pub mod export;
pub mod frame_store;
pub mod interrupt;
pub mod kitti;
pub mod lens_rays;
pub mod mount;
pub mod opencv_calib;
pub mod output;
pub mod path;
pub mod plot;
pub mod render;
pub mod run;
pub mod scenario;
pub mod sensitivity;
pub mod simulate;
pub mod soak;

/// Hears of long work: [`start`](Self::start) once with the number of steps, then
/// [`step`](Self::step) as each is done, possibly from several threads. The command line shows
/// a progress bar; `()` hears nothing.
pub trait Progress: Sync {
    /// The work has `total` steps.
    fn start(&self, total: usize) {
        let _ = total;
    }
    /// One more step is done.
    fn step(&self) {}
}

impl Progress for () {}
