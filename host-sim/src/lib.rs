//! Host side of roadvo: everything around the core that needs `std`. Synthetic drives with exact
//! ground truth ([`scenario`], [`path`], [`render`], [`simulate`]), mount calibration against
//! ground truth ([`calibrate`]), the paper's sensitivity study ([`sensitivity`]), the KITTI file layout
//! ([`kitti`]), the mount file users write for their vehicles ([`mount`]), the KITTI metric
//! ([`eval`]), runs of the odometer over a sequence ([`run`]), plots ([`plot`]) and the firmware example's
//! frame store ([`frame_store`]). The `roadvo` binary is a thin command line over these.

pub mod calibrate;
pub mod eval;
pub mod frame_store;
pub mod kitti;
pub mod mount;
pub mod path;
pub mod plot;
pub mod render;
pub mod run;
pub mod scenario;
pub mod sensitivity;
pub mod simulate;
