//! The CPU time of the calling thread: the paper's τ_c (Eq. 69) is CPU time per collision, which
//! on a shared machine is not the wall time.

/// CPU time consumed by the calling thread so far, in seconds (0 where the clock is missing).
pub fn thread_cpu_seconds() -> f64 {
    let mut now = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `now` is a valid, writable timespec; CLOCK_THREAD_CPUTIME_ID exists on Linux and
    // macOS; on failure the call leaves `now` at zero.
    unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut now) };
    now.tv_sec as f64 + now.tv_nsec as f64 * 1e-9
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_thread_clock_advances_with_work_not_with_sleep() {
        let start = thread_cpu_seconds();
        let mut x = 1.0f64;
        for i in 0..5_000_000 {
            x = (x + f64::from(i)).sqrt();
        }
        std::hint::black_box(x);
        let worked = thread_cpu_seconds() - start;
        assert!(worked > 0.0, "no CPU time measured");
        let before_sleep = thread_cpu_seconds();
        std::thread::sleep(std::time::Duration::from_millis(100));
        assert!(
            thread_cpu_seconds() - before_sleep < 0.05,
            "sleeping counted as CPU time"
        );
    }
}
