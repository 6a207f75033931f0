//! The clock of the study's timings: the CPU time of the calling thread
//! (`CLOCK_THREAD_CPUTIME_ID`), so that other processes on the machine do not inflate a
//! run's cost; monotonic wall time where that clock is missing.

/// CPU time of the calling thread, s (monotonic wall time since the first call where the
/// thread clock is unavailable). Only differences are meaningful.
pub fn thread_cpu_time() -> f64 {
    #[cfg(unix)]
    {
        let mut ts = libc::timespec {
            tv_sec: 0,
            tv_nsec: 0,
        };
        // SAFETY: `ts` is a valid, writable timespec and the clock id is a constant.
        let rc = unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) };
        if rc == 0 {
            return ts.tv_sec as f64 + ts.tv_nsec as f64 * 1e-9;
        }
    }
    wall_clock()
}

/// Monotonic wall time since the first call, s.
pub fn wall_clock() -> f64 {
    use std::sync::OnceLock;
    static START: OnceLock<std::time::Instant> = OnceLock::new();
    START
        .get_or_init(std::time::Instant::now)
        .elapsed()
        .as_secs_f64()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn thread_clock_advances_with_work() {
        let t0 = thread_cpu_time();
        let mut x = 0.0f64;
        for i in 0..2_000_000 {
            x += (i as f64).sqrt();
        }
        assert!(x > 0.0);
        assert!(thread_cpu_time() > t0);
    }
}
