//! The render's worker threads, one to a CPU. Left to the kernel, two
//! workers on a 2-CPU machine shared one CPU for part of a render now and
//! then: a third of the gold sphere's 1-spp renders (256², 17 ms) took
//! 17.5–21 ms instead of 16–16.5, every phase of them alike. Pinned, 25
//! renders in a row took 16.0–16.9 ms.
//!
//! Pinned only where the pool has a worker for each CPU the process may
//! run on (the default): a pool of fewer workers pinned to the first CPUs
//! would crowd them with every other such process's, where the kernel
//! spreads them out.

/// The CPUs this process may run on (its affinity mask), in order; None
/// where that cannot be known.
pub fn allowed_cpus() -> Option<Vec<usize>> {
    #[cfg(target_os = "linux")]
    {
        // SAFETY: a zeroed cpu_set_t is an empty set, which
        // sched_getaffinity fills; CPU_ISSET reads within it.
        unsafe {
            let mut set: libc::cpu_set_t = std::mem::zeroed();
            if libc::sched_getaffinity(0, std::mem::size_of::<libc::cpu_set_t>(), &mut set) != 0 {
                return None;
            }
            Some((0..libc::CPU_SETSIZE as usize).filter(|&cpu| libc::CPU_ISSET(cpu, &set)).collect())
        }
    }
    #[cfg(not(target_os = "linux"))]
    None
}

/// Where worker `index` of a pool of `workers` goes: the index-th allowed
/// CPU, where there are exactly `workers` of them.
pub fn cpu_for(index: usize, workers: usize, allowed: &[usize]) -> Option<usize> {
    (allowed.len() == workers).then(|| allowed.get(index).copied()).flatten()
}

/// Keeps the calling thread on `cpu`; a refusal (a CPU taken away since)
/// leaves it where the kernel puts it.
pub fn pin_current_thread(cpu: usize) {
    #[cfg(target_os = "linux")]
    // SAFETY: the set is built in place and passed with its own size.
    unsafe {
        let mut set: libc::cpu_set_t = std::mem::zeroed();
        libc::CPU_SET(cpu, &mut set);
        libc::sched_setaffinity(0, std::mem::size_of::<libc::cpu_set_t>(), &set);
    }
    #[cfg(not(target_os = "linux"))]
    let _ = cpu;
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_worker_a_cpu_only_where_the_pool_fills_the_allowed_cpus() {
        let allowed = [2, 3, 6];
        assert_eq!((0..3).map(|i| cpu_for(i, 3, &allowed)).collect::<Vec<_>>(), [Some(2), Some(3), Some(6)]);
        assert_eq!(cpu_for(0, 2, &allowed), None);
        assert_eq!(cpu_for(0, 4, &allowed), None);
    }

    #[cfg(target_os = "linux")]
    #[test]
    fn a_pinned_thread_runs_on_its_cpu_alone() {
        let allowed = allowed_cpus().expect("Linux reports the affinity mask");
        assert!(!allowed.is_empty());
        let cpu = *allowed.last().unwrap();
        let seen = std::thread::spawn(move || {
            pin_current_thread(cpu);
            allowed_cpus().unwrap()
        })
        .join()
        .unwrap();
        assert_eq!(seen, [cpu]);
    }
}
