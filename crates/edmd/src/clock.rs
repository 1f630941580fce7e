//! The CPU time of the calling thread: the paper's τ_c (Eq. 69) is CPU time per collision, which
//! on a shared machine is not the wall time.

/// CPU time consumed by the calling thread so far, in seconds (0 where the clock is missing).
pub fn thread_cpu_seconds() -> f64 {
    cpu_time::ThreadTime::try_now().map_or(0.0, |now| now.as_duration().as_secs_f64())
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
