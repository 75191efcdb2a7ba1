//! roadvo on a Cortex-M7, as an ECU integrates it: the configuration compiled in (exported from
//! a mount file by `roadvo export-config --rust`) and validated once at boot, the odometer in a
//! zero-initialised `static`, then one call to `process` per camera frame.
//!
//! The camera is stood in for by a recorded drive in the board's frame memory (the core's
//! `wire::frame_store`; `scripts/firmware` packs one with `roadvo pack`, loads it into QEMU's
//! PSRAM and compares what this firmware logs with the host's run, bit for bit). The drive must
//! have been packed with this firmware's configuration. Each estimate goes out through defmt
//! over semihosting, and again through the core's heading smoother as the configuration's
//! `smooth_lag_frames` says; QEMU exits with 0 when the drive is done and 1 on any error (a
//! refused configuration, a panic included).
#![no_std]
#![no_main]

mod log;
mod stack;

/// The configuration: `pub const CONFIG: roadvo::Config`, from the file the build's
/// `ROADVO_CONFIG_RS` names (`roadvo export-config MOUNT --rust`), else `src/default_config.rs`
/// (see `build.rs`).
mod config {
    include!(concat!(env!("OUT_DIR"), "/config.rs"));
}

use cortex_m_rt::entry;
use cortex_m_semihosting::debug::{self, EXIT_FAILURE, EXIT_SUCCESS};
use roadvo::wire::frame_store::{FrameStore, StoreError};
use roadvo::wire::{config_words, trace};
use roadvo::{ConfigError, Estimate, FrameError, Method, Odometer, Smoother, SmootherError};

/// Why the replay stopped.
#[derive(defmt::Format)]
enum Error {
    /// The frame memory holds no usable drive.
    Store(StoreError),
    /// The configuration compiled in is refused.
    Config(ConfigError),
    /// The drive in the frame memory was packed with another configuration than this
    /// firmware's.
    OtherConfig,
    /// The stored rows do not cover the rows the odometer reads.
    RowsMissing {
        /// First row the odometer reads.
        first: u16,
        /// One past the last.
        end: u16,
    },
    /// The smoother's capacity does not hold its lag.
    Smoother(SmootherError),
    /// The odometer refused a frame.
    Frame {
        /// Frame number.
        index: u32,
        /// What was wrong with it.
        error: FrameError,
    },
}

impl From<StoreError> for Error {
    fn from(e: StoreError) -> Self {
        Self::Store(e)
    }
}

impl From<SmootherError> for Error {
    fn from(e: SmootherError) -> Self {
        Self::Smoother(e)
    }
}

impl From<ConfigError> for Error {
    fn from(e: ConfigError) -> Self {
        Self::Config(e)
    }
}

/// The camera's frame memory, as the board's memory map (`memory.x`) places it.
fn camera_memory() -> &'static [u8] {
    #[allow(unsafe_code)]
    unsafe extern "C" {
        static _camera_memory_start: u8;
        static _camera_memory_end: u8;
    }
    let start = &raw const _camera_memory_start;
    let len = (&raw const _camera_memory_end) as usize - start as usize;
    // SAFETY: the region is RAM of the board (memory.x), filled before reset by whatever plays the
    // camera (QEMU's loader here), and nothing in this program writes it.
    #[allow(unsafe_code)]
    unsafe {
        core::slice::from_raw_parts(start, len)
    }
}

/// Marks the start of a call to `process` for the instruction counter (`scripts/qemu-icount.c`
/// counts from the entry of this function to the entry of [`roadvo_frame_end`]).
#[inline(never)]
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub extern "C" fn roadvo_frame_begin() {
    // Unlike bodies, so that the two markers are never merged into one function.
    core::hint::black_box(1u32);
}

/// Marks the end of a call to `process`.
#[inline(never)]
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub extern "C" fn roadvo_frame_end() {
    core::hint::black_box(2u32);
}

/// Validates the configuration compiled in and gives it to `odometer`, once at boot. Not inlined:
/// validation's temporaries (the homographies in f64) then share no stack frame with `process`.
#[inline(never)]
fn boot(odometer: &mut Odometer) -> Result<(), Error> {
    let config = config::CONFIG.validate()?;
    odometer.configure(config)?;
    Ok(())
}

/// Checks that the drive in the frame memory was packed with the odometer's configuration and
/// holds the rows it reads.
fn check_drive(odometer: &Odometer, store: &FrameStore) -> Result<(), Error> {
    let ours = config_words(odometer.config().config());
    if config_words(&store.header().config) != ours {
        return Err(Error::OtherConfig);
    }
    let rows = odometer.config().rows_read();
    if !store.holds_rows(rows.clone()) {
        return Err(Error::RowsMissing {
            first: rows.start,
            end: rows.end,
        });
    }
    Ok(())
}

/// One frame through the odometer, between the instruction counter's markers. Not inlined, so
/// that its stack frame is its own.
#[inline(never)]
fn step(
    odometer: &mut Odometer,
    frame: &roadvo::wire::frame_store::BandFrame,
    timestamp: roadvo::Instant,
) -> Result<Estimate, FrameError> {
    roadvo_frame_begin();
    let estimate = odometer.process(frame, timestamp);
    roadvo_frame_end();
    estimate
}

/// Replays the drive in the frame memory through `odometer`, logging every estimate.
fn replay(odometer: &mut Odometer) -> Result<(), Error> {
    let store = FrameStore::open(camera_memory())?;
    check_drive(odometer, &store)?;
    let rows = odometer.config().rows_read();
    let camera = odometer.config().config().camera;
    defmt::println!(
        "odometer {=usize} bytes, reading rows {=u16}..{=u16} of {=u16}x{=u16} frames",
        size_of::<Odometer>(),
        rows.start,
        rows.end,
        camera.width_px,
        camera.height_px
    );
    let settings = odometer.config().settings();
    // The paper's method stays as written: no smoother.
    let lag = match settings.method {
        Method::PitchVote => settings.smooth_lag_frames,
        Method::Paper => 0,
    };
    // On the replay's stack for the whole drive: up to four frames of lag.
    let mut smoother: Smoother<9> = Smoother::new(lag)?;
    let mut smoothed = 0u32;
    for index in 0..store.header().frames {
        let Some((frame, timestamp)) = store.frame(index) else {
            return Err(StoreError::Truncated.into());
        };
        let e = step(odometer, &frame, timestamp).map_err(|error| Error::Frame { index, error })?;
        log_estimate("estimate", index, &e);
        defmt::debug!("{}", e);
        if let Some(s) = smoother.push(e, timestamp).filter(|_| lag > 0) {
            log_estimate("smoothed", smoothed, &s);
            smoothed += 1;
        }
    }
    while let Some(s) = smoother.flush() {
        log_estimate("smoothed", smoothed, &s);
        smoothed += 1;
    }
    let pose = odometer.pose();
    defmt::println!(
        "final pose after {=u32} frames: x {=f32} m, y {=f32} m, heading {=f32} rad",
        store.header().frames,
        pose.x_m,
        pose.y_m,
        pose.heading_rad
    );
    // What an ECU would keep in non-volatile memory for the next ignition.
    let c = odometer.calibration();
    defmt::println!(
        "learned mount: yaw {=f32} rad, pitch {=f32} rad, roll {=f32} rad, x {=f32} m from the mount file's over {=f32} m; saved as {=[u8]:x}",
        odometer.learned_yaw().map_or(0.0, |e| e.rad),
        c.pitch().map_or(0.0, |e| e.rad),
        c.roll().map_or(0.0, |e| e.rad),
        c.x_ahead().map_or(0.0, |(m, _)| m),
        c.distance_m,
        c.to_bytes()[..]
    );
    Ok(())
}

/// Logs frame `index`'s estimate `e` as `kind` (`estimate` or `smoothed`): its trace record
/// (`roadvo::wire::trace`), for the comparison with the host (`roadvo run --trace`).
fn log_estimate(kind: &str, index: u32, e: &Estimate) {
    let [a, b, c, d, f, g, h, i, j, k, l] = trace::record(e);
    defmt::println!(
        "{=str} {=u32} {=u32} {=u32} {=u32} {=u32} {=u32} {=u32} {=u32} {=u32} {=u32} {=u32} {=u32}",
        kind,
        index,
        a,
        b,
        c,
        d,
        f,
        g,
        h,
        i,
        j,
        k,
        l
    );
}

#[entry]
fn main() -> ! {
    // cortex-m-rt hands this to `main` alone as a `&'static mut`. Every byte of it is zero, so it
    // sits in .bss: no flash, no copy at reset, and never built on the stack.
    static mut ODOMETER: Odometer = Odometer::UNCONFIGURED;
    let status = match boot(ODOMETER) {
        Err(e) => {
            defmt::error!("configuration refused at boot: {}", e);
            EXIT_FAILURE
        }
        Ok(()) => match replay(ODOMETER) {
            Ok(()) => EXIT_SUCCESS,
            Err(e) => {
                defmt::error!("replay stopped: {}", e);
                EXIT_FAILURE
            }
        },
    };
    defmt::println!(
        "stack high-water mark {=usize} bytes",
        stack::high_water_bytes()
    );
    exit(status)
}

/// Ends the run: QEMU exits with 0 for success, 1 otherwise.
fn exit(status: debug::ExitStatus) -> ! {
    debug::exit(status);
    // Only on a board without a debugger attached: nothing to return to.
    loop {
        cortex_m::asm::wfi();
    }
}

#[cfg(not(feature = "panic-check"))]
#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    defmt::error!("panic: {}", defmt::Display2Format(info));
    exit(EXIT_FAILURE)
}

/// With `panic-check`, any panic path left in the program fails the link on this symbol.
#[cfg(feature = "panic-check")]
#[panic_handler]
fn panic(_: &core::panic::PanicInfo) -> ! {
    #[allow(unsafe_code)]
    unsafe extern "C" {
        fn roadvo_firmware_must_not_panic() -> !;
    }
    // SAFETY: never runs: the symbol exists nowhere, so a build that needs it does not link.
    #[allow(unsafe_code)]
    unsafe {
        roadvo_firmware_must_not_panic()
    }
}
