//! The boards' panic handler: "Panicked at file:line:column" into the `PANDUMP` RAM region
//! (`memory.x`, symbols `_panic_dump_start` and `_panic_dump_end`) in panic-persist's record
//! format, then a reset; the next start reads it back with
//! `panic_persist::get_panic_message_bytes` and reports it.
//!
//! It is panic-persist's `min-panic` message without `core::fmt`: formatting even the
//! location through `core::fmt` links 1.7 KiB of it, and any panic's own arguments
//! (e.g. `f32::clamp`'s NaN check) would link core's float formatting, 20 KiB more, past
//! the boards' 64 KiB. Those arguments are dropped only because the handler reads nothing
//! but the location: LTO then passes the location alone and deletes the argument
//! construction at every panic site. With this crate at the release profile's opt-level 3
//! it does; the same handler inside the opt-level "s" firmware crate did not (checked with
//! rustc 1.95), and neither did a digit loop here behind `core::hint::black_box`. Hence a
//! crate of its own, kept out of the size overrides in the workspace `Cargo.toml`; `.ci/run`
//! fails if a board ELF links `core::fmt` again.
#![no_std]

use core::panic::{Location, PanicInfo};

#[panic_handler]
fn panic(info: &PanicInfo) -> ! {
    // The location is the only part of `info` read, first thing: see the crate docs.
    let location = info.location();
    cortex_m::interrupt::disable();
    record(location);
    cortex_m::peripheral::SCB::sys_reset()
}

/// Writes the record of a panic at `location`.
fn record(location: Option<&Location>) {
    let mut record = Record::start();
    match location {
        Some(location) => {
            record.push(b"Panicked at ");
            record.push(location.file().as_bytes());
            record.push(b":");
            record.push_decimal(location.line());
            record.push(b":");
            record.push_decimal(location.column());
        }
        None => record.push(b"Panicked (no location)"),
    }
}

/// panic-persist 0.3's record: the magic word 0x0FAC_ADE0, the length in bytes, then the
/// message, truncated to the region.
struct Record {
    start: *mut u8,
    capacity: usize,
    len: usize,
}

impl Record {
    const MAGIC: u32 = 0x0FAC_ADE0;
    const HEADER: usize = 8;

    /// An empty record, marked as present.
    fn start() -> Self {
        extern "C" {
            static mut _panic_dump_start: u8;
            static mut _panic_dump_end: u8;
        }
        let start = core::ptr::addr_of_mut!(_panic_dump_start);
        let end = core::ptr::addr_of_mut!(_panic_dump_end);
        let capacity = (end as usize)
            .saturating_sub(start as usize)
            .saturating_sub(Self::HEADER);
        // SAFETY: the linker script reserves [start, end) for this record alone, outside
        // .data, .bss and the stack; interrupts are off and the caller never returns.
        unsafe {
            start.cast::<u32>().write_unaligned(Self::MAGIC);
            start.add(4).cast::<u32>().write_unaligned(0);
        }
        Record {
            start,
            capacity,
            len: 0,
        }
    }

    /// Appends as much of `bytes` as fits and updates the length.
    fn push(&mut self, bytes: &[u8]) {
        let n = bytes.len().min(self.capacity - self.len);
        // SAFETY: HEADER + len + n <= HEADER + capacity: inside the region (see `start`).
        unsafe {
            core::ptr::copy_nonoverlapping(
                bytes.as_ptr(),
                self.start.add(Self::HEADER + self.len),
                n,
            );
        }
        self.len += n;
        // SAFETY: the length word is inside the region's header.
        unsafe {
            self.start
                .add(4)
                .cast::<u32>()
                .write_unaligned(self.len as u32);
        }
    }

    /// Appends `value` in decimal (recursively: a digit loop with a known bound is
    /// unrolled ten times at opt-level 3, half a KiB for a cold path).
    fn push_decimal(&mut self, value: u32) {
        if value >= 10 {
            self.push_decimal(value / 10);
        }
        self.push(&[b'0' + (value % 10) as u8]);
    }
}
