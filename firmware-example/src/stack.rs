//! The stack's high-water mark: cortex-m-rt's `paint-stack` fills the stack with
//! `STACK_PAINT_VALUE` at reset; the lowest word no longer holding it is as deep as the stack
//! has ever gone.

use cortex_m_rt::STACK_PAINT_VALUE;

#[allow(unsafe_code)]
unsafe extern "C" {
    /// Lowest address of the stack (cortex-m-rt's `link.x`: just past `.bss` and `.uninit`).
    static _stack_end: u32;
    /// Highest address of the stack, where it starts (the end of RAM).
    static _stack_start: u32;
}

/// Deepest the stack has been since reset, bytes.
pub fn high_water_bytes() -> usize {
    let bottom = (&raw const _stack_end) as usize;
    let top = (&raw const _stack_start) as usize;
    let mut addr = bottom;
    while addr < top {
        // SAFETY: `bottom..top` is RAM (the stack region of the linker script), word-aligned
        // (link.x asserts both ends are), and below the stack pointer nobody else writes it.
        #[allow(unsafe_code)]
        let word = unsafe { core::ptr::read_volatile(addr as *const u32) };
        if word != STACK_PAINT_VALUE {
            break;
        }
        addr += 4;
    }
    top - addr
}
