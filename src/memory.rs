//! Memory: how much the process has used, for `--stats` and the
//! benchmarks; large zeroed buffers whose pages the kernel maps in one
//! call rather than one fault at a time; and loads into the cache ahead of
//! a read.

use crate::Vec3;
use std::alloc::Layout;

/// The process's peak resident set in KiB (VmHWM), where the OS reports it.
pub fn peak_rss_kib() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    line.split_whitespace().nth(1)?.parse().ok()
}

/// `n` zero vectors from the allocator's zeroed memory: a large block is
/// fresh pages the kernel maps as they are first touched, or all at once
/// by `map_for_writing`.
pub fn zeroed_vec3s(n: usize) -> Vec<Vec3> {
    let Ok(layout) = Layout::array::<Vec3>(n) else { return vec![Vec3::ZERO; n] };
    if layout.size() == 0 {
        return Vec::new();
    }
    // SAFETY: the layout is Vec<Vec3>'s own for capacity n, and not empty;
    // zeroed memory holds n valid vectors (0.0 is all zero bits), so the
    // Vec owns an initialised allocation it can free.
    unsafe {
        let p = std::alloc::alloc_zeroed(layout);
        if p.is_null() {
            std::alloc::handle_alloc_error(layout);
        }
        Vec::from_raw_parts(p.cast::<Vec3>(), n, n)
    }
}

/// Has the kernel map the whole pages of `v` in one call, where fresh
/// ones would each fault as first written: a 256² film (1 MB) took 256
/// faults one by one, 0.36 ms of a 1-spp render's 17 on these virtual
/// machines. Changes no value of `v`.
pub fn map_for_writing(v: &mut [Vec3]) {
    populate(v.as_mut_ptr().cast::<u8>(), std::mem::size_of_val(v));
}

/// Maps the whole pages within `len` bytes at `p` for writing. A hint: a
/// kernel without MADV_POPULATE_WRITE (before Linux 5.14) refuses it, and
/// the pages then fault in as they are first written.
#[cfg(target_os = "linux")]
fn populate(p: *mut u8, len: usize) {
    // SAFETY: sysconf reads a constant; madvise is given whole pages of
    // this allocation only, and populating changes no byte of them.
    unsafe {
        let page = match libc::sysconf(libc::_SC_PAGESIZE) {
            size if size > 0 => size as usize,
            _ => return,
        };
        let start = (p as usize).next_multiple_of(page);
        let end = (p as usize + len) / page * page;
        if end > start {
            libc::madvise(start as *mut libc::c_void, end - start, libc::MADV_POPULATE_WRITE);
        }
    }
}

#[cfg(not(target_os = "linux"))]
fn populate(_: *mut u8, _: usize) {}

/// Asks the CPU to load every cache line `value` lies on (a hint: it
/// cannot fault, and does nothing where there is no such instruction).
#[inline(always)]
pub fn prefetch<T>(value: &T) {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
        let start = value as *const T as *const i8;
        // From the start of the line `value` begins on to its end.
        let mut line = start.wrapping_sub(start as usize % 64);
        let end = start.wrapping_add(std::mem::size_of::<T>());
        while line < end {
            // SAFETY: a prefetch never faults, whatever the address.
            unsafe { _mm_prefetch::<_MM_HINT_T0>(line) };
            line = line.wrapping_add(64);
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = value;
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every size from none to more than a page's worth holds zeros,
    /// mapped or not, and can be written, grown and dropped like any Vec.
    #[test]
    fn zeroed_vectors_are_zero_and_owned() {
        for n in [0, 1, 255, 256, 257, 65536, 1 << 20] {
            let mut v = zeroed_vec3s(n);
            assert_eq!(v.len(), n);
            assert!(v.iter().all(|x| *x == Vec3::ZERO), "{n}");
            map_for_writing(&mut v);
            assert!(v.iter().all(|x| *x == Vec3::ZERO), "{n} mapped");
            v.iter_mut().enumerate().for_each(|(i, x)| *x = Vec3::splat(i as f32));
            v.push(Vec3::ONE);
            assert_eq!(v[n], Vec3::ONE);
            assert!(n == 0 || v[n - 1] == Vec3::splat((n - 1) as f32));
            // Mapping a written slice, or part of one, keeps its values.
            map_for_writing(&mut v[n / 3..]);
            assert!(v[..=n].iter().enumerate().all(|(i, x)| *x == if i < n { Vec3::splat(i as f32) } else { Vec3::ONE }), "{n} after writing");
        }
    }
}
