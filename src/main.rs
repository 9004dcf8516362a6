//! The `deformesh` program: the command line of [`deformesh::app::cli`],
//! with an allocator whose failure ends the run with a message and the
//! Ctrl-C handler that removes staged outputs (a process's, not a
//! library's: the Python package's `deformesh` command sets the handler
//! too, but not the allocator).

use deformesh::app::driver::exit;
use std::alloc::{GlobalAlloc, Layout, System};

/// The system's allocator, except that an allocation that fails ends the
/// run with a message and [`exit::MEMORY`] instead of an abort. Outputs
/// are renamed into place only at the end, so nothing is half-written.
struct Allocator;

#[global_allocator]
static ALLOCATOR: Allocator = Allocator;

// SAFETY: every call is the system allocator's, with the same arguments
unsafe impl GlobalAlloc for Allocator {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        let p = unsafe { System.alloc(layout) };
        if p.is_null() {
            out_of_memory(layout.size());
        }
        p
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        let p = unsafe { System.alloc_zeroed(layout) };
        if p.is_null() {
            out_of_memory(layout.size());
        }
        p
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        let p = unsafe { System.realloc(ptr, layout, new_size) };
        if p.is_null() {
            out_of_memory(new_size);
        }
        p
    }
}

/// Text written into a buffer on the stack: the out-of-memory message
/// must not allocate.
struct StackText {
    buf: [u8; 768],
    len: usize,
}

impl std::fmt::Write for StackText {
    fn write_str(&mut self, s: &str) -> std::fmt::Result {
        let n = s.len().min(self.buf.len() - self.len);
        self.buf[self.len..self.len + n].copy_from_slice(&s.as_bytes()[..n]);
        self.len += n;
        Ok(())
    }
}

/// Says that an allocation of `size` bytes failed, and under which limit,
/// and ends the process with [`exit::MEMORY`] (no allocation, no unwinding).
fn out_of_memory(size: usize) -> ! {
    use std::fmt::Write;
    let mut text = StackText { buf: [0; 768], len: 0 };
    let mib = |b: u64| b as f64 / (1024.0 * 1024.0);
    let _ = write!(text, "\nerror: out of memory: an allocation of {:.0} MiB failed", mib(size as u64));
    #[cfg(unix)]
    {
        let mut r = libc::rlimit { rlim_cur: 0, rlim_max: 0 };
        // SAFETY: getrlimit writes the struct it is given
        // rlim_t is not u64 on every Unix
        #[allow(clippy::unnecessary_cast)]
        if unsafe { libc::getrlimit(libc::RLIMIT_AS, &mut r) } == 0 && r.rlim_cur != libc::RLIM_INFINITY {
            let _ = write!(text, " under the address-space limit (RLIMIT_AS, `ulimit -v`) of {:.0} MiB", mib(r.rlim_cur as u64));
        }
    }
    let _ = writeln!(text, "; nothing was written. Ask for less (a lower --order, a coarser mesh, Algorithm 2 in its band rather than --band all) or run where more memory is available");
    #[cfg(unix)]
    // SAFETY: write and _exit are async-signal-safe and allocate nothing
    unsafe {
        libc::write(2, text.buf.as_ptr().cast(), text.len);
        libc::_exit(exit::MEMORY);
    }
    #[cfg(not(unix))]
    std::process::abort()
}

/// glibc's malloc raises its threshold for giving a block its own pages
/// to the size of each such block freed (up to 32 MiB); after that the
/// large arrays of a run (a patch run's per-node vectors, the writers'
/// texts) are carved from the heap, and their pages stay with the process
/// when they are freed. Held at 256 KiB, they go back to the system:
/// measured on the 1e-5 extruded layer (60,596 hexes) at p = 2, the peak
/// resident memory fell from 1,006 MB to 829 MB.
#[cfg(all(target_os = "linux", target_env = "gnu"))]
fn hold_mmap_threshold() {
    // SAFETY: mallopt only sets one of the allocator's parameters
    unsafe {
        libc::mallopt(libc::M_MMAP_THRESHOLD, 256 * 1024);
    }
}

fn main() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    hold_mmap_threshold();
    tracing_subscriber::fmt()
        .with_env_filter(tracing_subscriber::EnvFilter::try_from_default_env().unwrap_or_else(|_| "warn".into()))
        .with_writer(std::io::stderr)
        .init();
    deformesh::io::folder::install_interrupt_handler();
    std::process::exit(deformesh::app::cli::main(std::env::args_os()));
}
