//! defmt's global logger, writing its frames to the host over semihosting (QEMU prints them on its
//! standard output; `defmt-print` decodes them).
//!
//! Like the `defmt-semihosting` crate, except that where that crate panics on a nested
//! `acquire` (a log call from inside a `Format` impl, or from a fault handler while a frame is
//! open) this logger drops the nested frame: the firmware's panic-free link check
//! (`--features panic-check`) allows no panic path anywhere in the program.

use core::cell::UnsafeCell;
use cortex_m_semihosting::hio::{self, HostStream};

#[defmt::global_logger]
struct Logger;

/// The logger's state; only touched inside the critical section `acquire` opens.
struct State {
    /// Open frames: 1 while a frame is written, more while nested calls are being dropped.
    depth: u32,
    restore: critical_section::RestoreState,
    encoder: defmt::Encoder,
    stdout: Option<HostStream>,
}

struct Shared(UnsafeCell<State>);

// SAFETY: the state is only reached inside a critical section (single core: interrupts off).
#[allow(unsafe_code)]
unsafe impl Sync for Shared {}

static STATE: Shared = Shared(UnsafeCell::new(State {
    depth: 0,
    restore: critical_section::RestoreState::invalid(),
    encoder: defmt::Encoder::new(),
    stdout: None,
}));

/// The state, for a caller inside the logger's critical section.
#[allow(unsafe_code)]
fn state() -> &'static mut State {
    // SAFETY: called only between `acquire` and `release`, inside their critical section, and
    // no reference outlives the call it was made in.
    unsafe { &mut *STATE.0.get() }
}

fn emit(stdout: &mut Option<HostStream>, bytes: &[u8]) {
    if let Some(out) = stdout {
        // Nowhere to report a failed write: the host went away.
        let _ = out.write_all(bytes);
    }
}

#[allow(unsafe_code)]
// SAFETY: `acquire` opens a critical section that `release` closes; the state is only touched
// inside it.
unsafe impl defmt::Logger for Logger {
    fn acquire() {
        // SAFETY: paired with the `release` below, or with `Logger::release`.
        let restore = unsafe { critical_section::acquire() };
        let s = state();
        if s.depth > 0 {
            // Nested: the outer call holds the section; this frame is dropped.
            s.depth += 1;
            // SAFETY: releases the section acquired just above, innermost first.
            unsafe { critical_section::release(restore) };
            return;
        }
        s.depth = 1;
        s.restore = restore;
        if s.stdout.is_none() {
            s.stdout = hio::hstdout().ok();
        }
        let State {
            encoder, stdout, ..
        } = s;
        encoder.start_frame(|b| emit(stdout, b));
    }

    unsafe fn flush() {
        // Semihosting blocks until the host has the bytes: nothing is buffered here.
    }

    unsafe fn release() {
        let s = state();
        match s.depth {
            0 => {}
            1 => {
                let State {
                    encoder, stdout, ..
                } = s;
                encoder.end_frame(|b| emit(stdout, b));
                s.depth = 0;
                // SAFETY: closes the section the outermost `acquire` opened.
                unsafe { critical_section::release(s.restore) };
            }
            _ => s.depth -= 1,
        }
    }

    unsafe fn write(bytes: &[u8]) {
        let s = state();
        if s.depth == 1 {
            let State {
                encoder, stdout, ..
            } = s;
            encoder.write(bytes, |b| emit(stdout, b));
        }
    }
}
