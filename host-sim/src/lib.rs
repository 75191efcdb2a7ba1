//! Host side of roadvo: everything around the core that needs `std`. Synthetic drives with exact
//! ground truth ([`scenario`], [`path`], [`render`] through [`lens_rays`], [`simulate`]), mount
//! calibration against ground truth ([`calibrate`]), the paper's sensitivity study
//! ([`sensitivity`]), the KITTI file layout ([`kitti`]) and the others a sequence may have
//! ([`layout`]: folders of frames ([`image_files`]) and videos ([`video`])), the mount file users
//! write for their vehicles ([`mount`]) and the OpenCV calibration it may name
//! ([`opencv_calib`]), trajectory files ([`pose_file`], [`associate`]), the KITTI metric
//! ([`eval`]) and evo's ([`ape`]), runs of the odometer over a sequence ([`run`], [`quality`]),
//! an hour's soak of one odometer ([`soak`]), plots ([`plot`]) and the firmware example's frame
//! store ([`frame_store`]). Outputs are written whole or not at all ([`output`]), inputs read
//! within size limits ([`input`]), and a Ctrl-C ends long work cleanly ([`interrupt`]); [`view`]
//! draws what the odometer sees. The `roadvo` binary is a thin command line over these.

pub mod ape;
pub mod associate;
pub mod calibrate;
pub mod eval;
pub mod export;
pub mod frame_store;
pub mod image_files;
pub mod input;
pub mod interrupt;
pub mod kitti;
pub mod layout;
pub mod lens_rays;
pub mod mount;
pub mod opencv_calib;
pub mod output;
pub mod path;
pub mod plot;
pub mod pose_file;
pub mod quality;
pub mod render;
pub mod run;
pub mod scenario;
pub mod sensitivity;
pub mod simulate;
pub mod soak;
pub mod video;
pub mod view;

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
