//! Running a foreign program as a child process, measured: spawn, timeout, resource usage,
//! stdout, the tail of stderr, how it ended.
//!
//! - The child is spawned from the calling thread, so on Linux it inherits that thread's CPU
//!   affinity (a worker slot's pinned core); it gets `OMP_NUM_THREADS=1` and `SWEEP_CORE` (the
//!   cores the caller may run on, comma-separated: one on a pinned slot).
//! - It leads a process group of its own: a timeout kills the whole group, and so does the end
//!   of the child (helpers it left behind would otherwise hold its pipes open).
//! - Wall time is measured around spawn and wait; CPU time is the `wait4` resource usage
//!   (user + system) of the child and of every descendant it waited for.
//!
//! The child is waited for without being reaped first (`waitid` with `WNOWAIT`): until it is
//! reaped its pid, hence its process group, cannot be reused, so killing the group is always
//! aimed at the right processes.

use std::collections::VecDeque;
use std::io::{self, Read};
use std::os::unix::process::CommandExt;
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::sync::mpsc;
use std::thread;
use std::time::{Duration, Instant};

/// Lines of stderr kept for a failure's reason.
pub const STDERR_LINES: usize = 20;
/// Stdout kept for parsing; beyond this it is read and dropped, so the child never blocks.
const STDOUT_LIMIT: usize = 64 << 20;
/// Stderr bytes kept (the tail) to find its last lines in.
const STDERR_KEEP: usize = 64 << 10;

/// How a child ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum End {
    /// Exited by itself with this status.
    Exited(i32),
    /// Killed by this signal (not ours).
    Signalled(i32),
    /// Ran past its timeout; its process group was killed.
    TimedOut,
}

/// What a child did.
#[derive(Debug)]
pub struct Outcome {
    pub end: End,
    /// Its stdout (at most 64 MiB; `stdout_truncated` says whether more was dropped).
    pub stdout: Vec<u8>,
    pub stdout_truncated: bool,
    /// The last [`STDERR_LINES`] lines of stderr.
    pub stderr_tail: Vec<String>,
    pub wall_s: f64,
    /// User + system time of the child and the descendants it waited for.
    pub cpu_s: f64,
}

/// Spawns of a program refused as "text file busy" tried again, the first after 1 ms and each
/// after twice as long as the one before (about 1 s in all).
const BUSY_RETRIES: u32 = 10;

/// Spawns `command`, and the instant just before the spawn that succeeded. A program that was
/// just written can be refused for a moment with ETXTBSY: a thread of this process that forked
/// while the file was open for writing holds it until that child execs (Linux; cargo and Go's
/// os/exec retry the same way). A program still busy after the retries is an error.
fn spawn_when_not_busy(command: &mut Command) -> io::Result<(Child, Instant)> {
    let mut wait = Duration::from_millis(1);
    for _ in 0..BUSY_RETRIES {
        let start = Instant::now();
        match command.spawn() {
            Err(e) if e.raw_os_error() == Some(libc::ETXTBSY) => {
                thread::sleep(wait);
                wait *= 2;
            }
            other => return other.map(|child| (child, start)),
        }
    }
    let start = Instant::now();
    command.spawn().map(|child| (child, start))
}

/// Runs `program` with `args` to its end or until `timeout` (`None`: no limit).
pub fn run(program: &Path, args: &[String], timeout: Option<Duration>) -> io::Result<Outcome> {
    let mut command = Command::new(program);
    command
        .args(args)
        .env("OMP_NUM_THREADS", "1")
        .env("SWEEP_CORE", allowed_cpus_text())
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .process_group(0);
    let (mut child, start) = spawn_when_not_busy(&mut command)?;
    let pid = child.id() as libc::pid_t;
    let stdout = child.stdout.take();
    let stderr = child.stderr.take();
    let stdout_reader = thread::spawn(move || read_capped(stdout));
    let stderr_reader = thread::spawn(move || read_tail(stderr));

    // The watchdog kills the group at the timeout unless told (or dropped) first.
    let (cancel, cancelled) = mpsc::channel::<()>();
    let watchdog = timeout.map(|limit| {
        thread::spawn(move || {
            if let Err(mpsc::RecvTimeoutError::Timeout) = cancelled.recv_timeout(limit) {
                // SAFETY: kill(2) with a negative pid signals the process group; the child is
                // not reaped yet (see the module's doc), so the group is still ours.
                unsafe { libc::kill(-pid, libc::SIGKILL) };
                true
            } else {
                false
            }
        })
    });
    let waited = wait_unreaped(pid);
    drop(cancel);
    let timed_out = watchdog.is_some_and(|w| w.join().unwrap_or(false));
    // Whatever the child left behind in its group goes with it.
    // SAFETY: as above; ESRCH (nothing left) is fine.
    unsafe { libc::kill(-pid, libc::SIGKILL) };
    let (status, usage) = reap(pid);
    let wall_s = start.elapsed().as_secs_f64();
    waited?;
    let (status, usage) = (status?, usage);
    let (stdout, stdout_truncated) = stdout_reader
        .join()
        .map_err(|_| io::Error::other("the stdout reader panicked"))??;
    let stderr_tail = stderr_reader
        .join()
        .map_err(|_| io::Error::other("the stderr reader panicked"))??;
    let end = if timed_out {
        End::TimedOut
    } else if libc::WIFSIGNALED(status) {
        End::Signalled(libc::WTERMSIG(status))
    } else {
        End::Exited(libc::WEXITSTATUS(status))
    };
    Ok(Outcome {
        end,
        stdout,
        stdout_truncated,
        stderr_tail,
        wall_s,
        cpu_s: seconds(usage.ru_utime) + seconds(usage.ru_stime),
    })
}

/// Blocks until `pid` has ended, leaving it a zombie (not reaped).
fn wait_unreaped(pid: libc::pid_t) -> io::Result<()> {
    loop {
        // SAFETY: an all-zero siginfo_t is a valid value to be written into.
        let mut info: libc::siginfo_t = unsafe { std::mem::zeroed() };
        // SAFETY: `info` is a valid, writable siginfo_t.
        let r = unsafe {
            libc::waitid(
                libc::P_PID,
                pid as libc::id_t,
                &mut info,
                libc::WEXITED | libc::WNOWAIT,
            )
        };
        if r == 0 {
            return Ok(());
        }
        let error = io::Error::last_os_error();
        if error.kind() != io::ErrorKind::Interrupted {
            return Err(error);
        }
    }
}

/// Reaps `pid`: its wait status and resource usage (its waited-for descendants included).
fn reap(pid: libc::pid_t) -> (io::Result<libc::c_int>, libc::rusage) {
    // SAFETY: an all-zero rusage is a valid value.
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    loop {
        let mut status: libc::c_int = 0;
        // SAFETY: `status` and `usage` are valid and writable.
        let r = unsafe { libc::wait4(pid, &mut status, 0, &mut usage) };
        if r == pid {
            return (Ok(status), usage);
        }
        let error = io::Error::last_os_error();
        if error.kind() != io::ErrorKind::Interrupted {
            return (Err(error), usage);
        }
    }
}

fn seconds(t: libc::timeval) -> f64 {
    t.tv_sec as f64 + t.tv_usec as f64 * 1e-6
}

fn read_capped(pipe: Option<impl Read>) -> io::Result<(Vec<u8>, bool)> {
    let mut kept = Vec::new();
    let mut truncated = false;
    let Some(mut pipe) = pipe else {
        return Ok((kept, truncated));
    };
    let mut buffer = [0u8; 1 << 16];
    loop {
        let n = match pipe.read(&mut buffer) {
            Ok(0) => return Ok((kept, truncated)),
            Ok(n) => n,
            Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
            Err(e) => return Err(e),
        };
        let room = STDOUT_LIMIT - kept.len();
        kept.extend_from_slice(&buffer[..n.min(room)]);
        truncated |= n > room;
    }
}

fn read_tail(pipe: Option<impl Read>) -> io::Result<Vec<String>> {
    let mut tail: VecDeque<u8> = VecDeque::new();
    if let Some(mut pipe) = pipe {
        let mut buffer = [0u8; 1 << 14];
        loop {
            let n = match pipe.read(&mut buffer) {
                Ok(0) => break,
                Ok(n) => n,
                Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
                Err(e) => return Err(e),
            };
            tail.extend(&buffer[..n]);
            let excess = tail.len().saturating_sub(STDERR_KEEP);
            tail.drain(..excess);
        }
    }
    let text = String::from_utf8_lossy(tail.make_contiguous()).into_owned();
    let lines: Vec<String> = text.lines().map(str::to_owned).collect();
    let skip = lines.len().saturating_sub(STDERR_LINES);
    Ok(lines.into_iter().skip(skip).collect())
}

/// The CPUs the calling thread may run on (`sched_getaffinity`), ascending.
pub fn allowed_cpus() -> Vec<usize> {
    // SAFETY: an all-zero cpu_set_t is the empty set.
    let mut set: libc::cpu_set_t = unsafe { std::mem::zeroed() };
    // SAFETY: `set` is valid and its size is passed.
    let r = unsafe { libc::sched_getaffinity(0, std::mem::size_of::<libc::cpu_set_t>(), &mut set) };
    if r != 0 {
        return Vec::new();
    }
    (0..libc::CPU_SETSIZE as usize)
        // SAFETY: `cpu` is below CPU_SETSIZE.
        .filter(|&cpu| unsafe { libc::CPU_ISSET(cpu, &set) })
        .collect()
}

fn allowed_cpus_text() -> String {
    allowed_cpus()
        .iter()
        .map(usize::to_string)
        .collect::<Vec<_>>()
        .join(",")
}

/// The conventional name of a signal (`SIGSEGV`), or `signal N`.
pub fn signal_name(signal: i32) -> String {
    let name = match signal {
        libc::SIGHUP => "SIGHUP",
        libc::SIGINT => "SIGINT",
        libc::SIGQUIT => "SIGQUIT",
        libc::SIGILL => "SIGILL",
        libc::SIGTRAP => "SIGTRAP",
        libc::SIGABRT => "SIGABRT",
        libc::SIGBUS => "SIGBUS",
        libc::SIGFPE => "SIGFPE",
        libc::SIGKILL => "SIGKILL",
        libc::SIGUSR1 => "SIGUSR1",
        libc::SIGSEGV => "SIGSEGV",
        libc::SIGUSR2 => "SIGUSR2",
        libc::SIGPIPE => "SIGPIPE",
        libc::SIGALRM => "SIGALRM",
        libc::SIGTERM => "SIGTERM",
        libc::SIGXCPU => "SIGXCPU",
        libc::SIGXFSZ => "SIGXFSZ",
        libc::SIGSYS => "SIGSYS",
        _ => return format!("signal {signal}"),
    };
    name.to_owned()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sh(script: &str, timeout: Option<Duration>) -> Outcome {
        run(
            Path::new("/bin/sh"),
            &["-c".to_owned(), script.to_owned()],
            timeout,
        )
        .expect("/bin/sh runs")
    }

    #[test]
    fn exit_status_stdout_and_stderr_tail() {
        let out = sh(
            "echo first; echo '{\"x\": 1}'; for i in $(seq 1 30); do echo err$i >&2; done; exit 3",
            None,
        );
        assert_eq!(out.end, End::Exited(3));
        assert_eq!(String::from_utf8_lossy(&out.stdout), "first\n{\"x\": 1}\n");
        assert_eq!(out.stderr_tail.len(), STDERR_LINES);
        assert_eq!(out.stderr_tail.first().map(String::as_str), Some("err11"));
        assert_eq!(out.stderr_tail.last().map(String::as_str), Some("err30"));
    }

    /// A program held open for writing (as by a thread that forked while it was being written)
    /// is run once it is closed, within the retries; one held past them is an error that says
    /// the file is busy.
    #[test]
    fn a_program_busy_for_a_moment_runs_once_it_is_free() {
        use std::io::Write;
        use std::os::unix::fs::OpenOptionsExt;
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("prog");
        let mut file = std::fs::OpenOptions::new()
            .write(true)
            .create_new(true)
            .mode(0o755)
            .open(&path)
            .expect("create");
        file.write_all(b"#!/bin/sh\necho '{\"ok\": 1}'\n")
            .expect("write");
        let held = thread::spawn(move || {
            thread::sleep(Duration::from_millis(30));
            drop(file);
        });
        let out = run(&path, &[], None).expect("runs once closed");
        held.join().expect("join");
        assert_eq!(out.end, End::Exited(0));
        assert_eq!(String::from_utf8_lossy(&out.stdout), "{\"ok\": 1}\n");
        let _busy = std::fs::OpenOptions::new()
            .write(true)
            .open(&path)
            .expect("open");
        let err = run(&path, &[], None).expect_err("busy past the retries");
        assert_eq!(err.raw_os_error(), Some(libc::ETXTBSY), "{err}");
    }

    #[test]
    fn a_signal_is_named() {
        let out = sh("kill -SEGV $$", None);
        assert_eq!(out.end, End::Signalled(libc::SIGSEGV));
        assert_eq!(signal_name(libc::SIGSEGV), "SIGSEGV");
        assert_eq!(signal_name(77), "signal 77");
    }

    /// The timeout kills the whole group: a grandchild holding stdout open would otherwise keep
    /// the readers (and the job) waiting for its 30 s.
    #[test]
    fn a_timeout_kills_the_process_group() {
        let start = Instant::now();
        let out = sh("sleep 30 & sleep 30", Some(Duration::from_millis(300)));
        assert_eq!(out.end, End::TimedOut);
        assert!(
            start.elapsed() < Duration::from_secs(10),
            "{:?}",
            start.elapsed()
        );
        assert!(out.wall_s >= 0.3, "{}", out.wall_s);
    }

    /// CPU time counts the children the program waited for; wall time covers a sleep that costs
    /// no CPU.
    #[test]
    fn cpu_time_includes_children() {
        let out = sh(
            "(i=0; while [ $i -lt 200000 ]; do i=$((i+1)); done) ; sleep 0.2",
            None,
        );
        assert_eq!(out.end, End::Exited(0));
        assert!(out.cpu_s > 0.05, "cpu {}", out.cpu_s);
        assert!(
            out.wall_s >= out.cpu_s * 0.5 && out.wall_s > 0.2,
            "wall {}",
            out.wall_s
        );
    }

    /// The child runs where the spawning thread may run, and is told so.
    #[test]
    fn the_child_inherits_the_threads_affinity() {
        let cpus = allowed_cpus();
        let Some(&last) = cpus.last() else {
            panic!("no CPU allowed?");
        };
        let seen = thread::spawn(move || {
            // SAFETY: an all-zero cpu_set_t is the empty set; `last` < CPU_SETSIZE.
            let mut set: libc::cpu_set_t = unsafe { std::mem::zeroed() };
            unsafe { libc::CPU_SET(last, &mut set) };
            // SAFETY: `set` is valid; 0 = the calling thread.
            let r = unsafe {
                libc::sched_setaffinity(0, std::mem::size_of::<libc::cpu_set_t>(), &set)
            };
            assert_eq!(r, 0, "pinning failed");
            sh(
                "grep Cpus_allowed_list /proc/self/status; echo core=$SWEEP_CORE omp=$OMP_NUM_THREADS",
                None,
            )
        })
        .join()
        .expect("thread");
        let text = String::from_utf8_lossy(&seen.stdout);
        assert!(
            text.contains(&format!("Cpus_allowed_list:\t{last}\n")),
            "{text}"
        );
        assert!(text.contains(&format!("core={last} omp=1")), "{text}");
    }

    #[test]
    fn a_missing_program_is_an_error() {
        assert!(run(Path::new("/nonexistent/program"), &[], None).is_err());
    }
}
