//! The generator's heap policy: `vadscope generate` and the generator benchmark stream
//! frames of tens of megabytes.
//!
//! glibc's malloc hands the free top of its heaps back to the kernel (above a threshold of a
//! few megabytes by default), so every generated 768×512 frame faults its ~40 MB of buffers
//! back in, page by page, zeroed by the kernel: about 5 % of the generator's CPU time.
//! Raising the thresholds keeps those pages in the process from one frame to the next. The
//! memory kept is what the frames in flight use anyway, and it goes back when the process
//! ends; commands that stay open (the viewer) keep glibc's defaults, which is why the
//! library never sets it on its own.

/// Largest mmap threshold glibc accepts (half its 64 MiB heap size on 64-bit): allocations
/// up to this size come from the heap and are reused instead of mapped and unmapped.
#[cfg(all(target_os = "linux", target_env = "gnu"))]
const MMAP_THRESHOLD: libc::c_int = 32 << 20;

/// Free memory a heap may keep at its top before malloc trims it.
#[cfg(all(target_os = "linux", target_env = "gnu"))]
const TRIM_THRESHOLD: libc::c_int = 512 << 20;

/// Keeps freed frame buffers in the process for reuse. Returns whether malloc took the
/// setting (only glibc has it; elsewhere this does nothing and returns `false`).
pub fn keep_freed_frame_buffers() -> bool {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    {
        // SAFETY: `mallopt` takes malloc's own lock and only changes tuning parameters,
        // which any thread may do at any time.
        unsafe {
            libc::mallopt(libc::M_MMAP_THRESHOLD, MMAP_THRESHOLD) == 1
                && libc::mallopt(libc::M_TRIM_THRESHOLD, TRIM_THRESHOLD) == 1
        }
    }
    #[cfg(not(all(target_os = "linux", target_env = "gnu")))]
    {
        false
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn glibc_accepts_the_thresholds() {
        let expected = cfg!(all(target_os = "linux", target_env = "gnu"));
        assert_eq!(keep_freed_frame_buffers(), expected);
    }
}
