//! Memory as a limit, not a crash: what a run may use (the address-space
//! limit `RLIMIT_AS`, the cgroup's limit, the memory available), what a
//! `curve` run needs (an estimate from the mesh's size and the order,
//! measured: see [`curve_estimate`]), and the message of a run that does
//! not fit, said before anything is allocated. An allocation that fails
//! all the same ends the binary with the same exit code and a message
//! (its global allocator: `main.rs`), not an abort.

use std::path::Path;

/// What the process may still allocate, and which limit says so.
#[derive(Clone, Debug, PartialEq)]
pub struct Headroom {
    /// Bytes.
    pub bytes: u64,
    /// The limit that leaves the least: "the address-space limit
    /// (RLIMIT_AS) of 2.9 GiB", "the cgroup's memory.max of …", "the
    /// available memory (MemAvailable) of …".
    pub what: String,
}

/// `bytes` for a person: "1.62 GiB", "380 MiB".
pub fn shown(bytes: u64) -> String {
    let b = bytes as f64;
    if b >= 1024.0 * 1024.0 * 1024.0 {
        format!("{:.2} GiB", b / (1024.0 * 1024.0 * 1024.0))
    } else {
        format!("{:.0} MiB", b / (1024.0 * 1024.0))
    }
}

/// The first number after `key` in `text` (a `/proc` file), times 1024
/// (those files count kB).
fn kb_field(text: &str, key: &str) -> Option<u64> {
    let line = text.lines().find(|l| l.starts_with(key))?;
    Some(line[key.len()..].split_whitespace().next()?.parse::<u64>().ok()? * 1024)
}

/// A number read from a one-line file (`max` and unreadable files: none).
fn number_in(path: &Path) -> Option<u64> {
    std::fs::read_to_string(path).ok()?.trim().parse().ok()
}

/// What the process may still allocate: the least of the address space
/// left under `RLIMIT_AS` (its limit less the process's size now), the
/// cgroup's limit less its usage, and the memory available; `None` where
/// none of them can be read (not Linux).
pub fn headroom() -> Option<Headroom> {
    let mut all: Vec<Headroom> = Vec::new();
    let status = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    #[cfg(unix)]
    {
        let mut r = libc::rlimit { rlim_cur: 0, rlim_max: 0 };
        // SAFETY: getrlimit writes the struct it is given
        // rlim_t is not u64 on every Unix
        #[allow(clippy::unnecessary_cast)]
        if unsafe { libc::getrlimit(libc::RLIMIT_AS, &mut r) } == 0 && r.rlim_cur != libc::RLIM_INFINITY {
            let used = kb_field(&status, "VmSize:").unwrap_or(0);
            all.push(Headroom { bytes: (r.rlim_cur as u64).saturating_sub(used), what: format!("the address-space limit (RLIMIT_AS, `ulimit -v`) of {}", shown(r.rlim_cur as u64)) });
        }
    }
    // cgroup v2, then v1
    let v2 = Path::new("/sys/fs/cgroup");
    let (max, current) = match number_in(&v2.join("memory.max")) {
        Some(max) => (Some(max), number_in(&v2.join("memory.current"))),
        None => (number_in(&v2.join("memory/memory.limit_in_bytes")).filter(|&m| m < 1 << 60), number_in(&v2.join("memory/memory.usage_in_bytes"))),
    };
    if let Some(max) = max {
        all.push(Headroom { bytes: max.saturating_sub(current.unwrap_or(0)), what: format!("the cgroup's memory limit of {}", shown(max)) });
    }
    if let Some(available) = std::fs::read_to_string("/proc/meminfo").ok().and_then(|t| kb_field(&t, "MemAvailable:")) {
        all.push(Headroom { bytes: available, what: format!("the memory available (MemAvailable) of {}", shown(available)) });
    }
    all.into_iter().min_by_key(|h| h.bytes)
}

/// Bytes a `curve` run needs at its peak, estimated from the order-`p`
/// nodes of the mesh (`nodes`, counted as Algorithm 2's subdivision makes
/// them), its dimension and whether Algorithm 2 solves on the whole mesh
/// (`--band all`) or in the band along the curved walls. The figures per
/// node are measured peaks (`/usr/bin/time -v`, maximum resident set) of
/// runs on meshes of each kind (README, "Memory"), rounded up; the base is
/// the process with its thread pool.
pub fn curve_estimate(dim: usize, nodes: u64, whole: bool) -> u64 {
    let per_node: u64 = match (dim, whole) {
        (2, false) => 1_700,
        (2, true) => 2_300,
        (_, false) => 4_500,
        (_, true) => 5_500,
    };
    BASE + per_node * nodes
}

/// The process before any mesh: code, thread pool and their stacks.
pub const BASE: u64 = 40 << 20;

/// The address space a process of this many threads takes beyond what it
/// allocates (stacks, the allocator's per-thread arenas): counted against
/// `RLIMIT_AS` only.
pub fn reserved_address_space() -> u64 {
    // glibc keeps up to 8 arenas of 64 MiB per core for threads
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get()) as u64;
    threads * (64 << 20)
}
