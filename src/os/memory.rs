//! The process's memory as the kernel and the C allocator see it: the peak resident size a
//! run reports with its file-backed part (the shared libraries' pages), the resident size
//! now (which the size check counts as the run's own), and the freed heap given back between
//! its phases.

/// Peak resident set size of this process in bytes: the kernel's high-water mark
/// (getrusage's ru_maxrss). PETSc's `PetscMemoryGetMaximumUsage` only samples the resident
/// size when PETSc objects are destroyed, so it missed transient peaks between them (the
/// estimate's: at n = 512 it reported 977 MiB where the high-water mark was 1304 MiB).
pub fn peak_memory() -> f64 {
    // SAFETY: getrusage fills the zeroed struct it is given.
    let mut r: libc::rusage = unsafe { std::mem::zeroed() };
    if unsafe { libc::getrusage(libc::RUSAGE_SELF, &mut r) } != 0 {
        return 0.0;
    }
    r.ru_maxrss as f64 * 1024.0 // kilobytes on Linux
}

/// This process's resident file-backed memory in bytes (`RssFile` in /proc/self/status): the
/// pages of its shared libraries (PETSc, MUMPS, MPI, HDF5 and the rest: about 44 MiB) and of
/// any file it maps. The ranks on one machine share these pages, so a sum of the ranks'
/// resident sizes counts them once per rank. 0 where the kernel does not say.
pub fn resident_file_backed() -> f64 {
    status_bytes("RssFile:")
}

/// This process's resident size in bytes now (`VmRSS` in /proc/self/status: anonymous,
/// file-backed and shared pages). 0 where the kernel does not say.
pub fn resident() -> f64 {
    status_bytes("VmRSS:")
}

/// The size `key` of /proc/self/status in bytes (the kernel gives kB), or 0.
fn status_bytes(key: &str) -> f64 {
    let status = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    status
        .lines()
        .find_map(|l| l.strip_prefix(key))
        .and_then(|v| v.trim().trim_end_matches("kB").trim().parse::<f64>().ok())
        .map_or(0.0, |kib| kib * 1024.0)
}

/// Give the heap's free pages back to the system (glibc's `malloc_trim`) when at least
/// `min_bytes` are free in it. Arrays under glibc's mmap threshold (which grows to 32 MiB
/// as large blocks are freed) live in the heap and stay resident after they are freed, so
/// without this a phase's freed arrays still count when the next phase allocates others.
/// Below the threshold the pages are kept: faulting them in again costs more than they
/// weigh.
pub fn release_free_memory(min_bytes: usize) {
    // SAFETY: mallinfo2 only reads the allocator's statistics, and malloc_trim only
    // returns unused pages of its own heaps.
    unsafe {
        if libc::mallinfo2().fordblks >= min_bytes {
            libc::malloc_trim(0);
        }
    }
}
