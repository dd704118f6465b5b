//! How the kernel schedules the gateway's threads against the rest of the
//! companion computer (video, vision, builds).
//!
//! On a loaded machine a thread woken by a frame waits for a CPU behind
//! whatever runs there: under Linux's EEVDF scheduler (6.6 and later) up to
//! a whole slice of the running task (1.4 ms by default on the 2-core test
//! machine), and more when several are queued, and Linux shares the CPUs
//! between sessions (autogroups) before it shares them between threads.
//! Measured on a saturated 2-core machine, only a real-time policy held
//! the reaction time's tail down (docs/benchmarks-history.md, "Under load
//! (issue 15)").
//!
//! So the loop that turns a frame into a command asks for one itself
//! ([`for_the_loop`]): `SCHED_FIFO` at [`LOOP_PRIORITY`] (`--realtime-priority`),
//! with the reset-on-fork flag, so that no thread or program it starts
//! inherits it. That needs root, `CAP_SYS_NICE` or an `RLIMIT_RTPRIO` as
//! high; refused, it says so once and asks for a short slice instead
//! (`sched_setattr`'s `sched_runtime` with the normal policy, Linux 6.12
//! and later, no privilege needed): its deadline comes sooner, so it may
//! preempt the running task when it wakes. A policy given from outside
//! (`chrt -f`, systemd's `CPUSchedulingPolicy=fifo`) is kept.
//!
//! The recorder's thread, whose work can wait, is put in the batch policy:
//! its wake-ups (every 10 ms) never preempt anyone, and it never runs at
//! the real-time priority the gateway has.
//!
//! All are requests: on another system or an older kernel (which ignores
//! the slice) nothing changes, and nothing fails.

/// The real-time priority the loop asks for by default (`SCHED_FIFO`): the
/// shipped unit's, low among real-time tasks and below the kernel's
/// threaded interrupt handlers (50), so that the network's and the serial
/// port's interrupts are served first.
pub const LOOP_PRIORITY: u32 = 10;

/// The slice the loop asks for: the kernel's shortest (100 µs).
pub const LOOP_SLICE_NS: u64 = 100_000;

/// What the kernel was asked, for the log.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Asked {
    /// Done.
    Granted,
    /// The thread runs under another policy (real-time, idle): left alone.
    LeftAlone,
    /// Not on Linux, or the kernel refused (the error number).
    Refused(i32),
}

/// Asks the real-time policy `SCHED_FIFO` at `priority` (1-99) for the
/// calling thread, with the reset-on-fork flag: threads and processes it
/// starts begin under the normal policy. A thread already under a
/// real-time policy (given from outside) or an idle or deadline one is
/// left alone. Refused (the error number) without the privilege.
pub fn real_time(priority: u32) -> Asked {
    imp::change(|attr| {
        if attr.sched_policy != imp::SCHED_OTHER && attr.sched_policy != imp::SCHED_BATCH {
            return false;
        }
        attr.sched_policy = imp::SCHED_FIFO;
        attr.sched_priority = priority;
        attr.sched_runtime = 0;
        attr.sched_flags = imp::SCHED_FLAG_RESET_ON_FORK;
        true
    })
}

/// What the gateway's loop asks of the kernel at start, on its own thread:
/// [`real_time`] at `priority`, else (none given, or refused) a
/// [`short_slice`]. A refusal is logged as a warning saying how to grant
/// it; the loop runs on either way.
pub fn for_the_loop(priority: Option<u32>) -> Asked {
    if let Some(priority) = priority {
        match real_time(priority) {
            Asked::Granted => {
                tracing::info!("the loop runs at real-time priority {priority} (SCHED_FIFO)");
                return Asked::Granted;
            }
            Asked::LeftAlone => {
                tracing::info!("the loop keeps the scheduling policy it was given");
                return Asked::LeftAlone;
            }
            Asked::Refused(e) => tracing::warn!(
                "the loop runs at the normal priority: real-time priority {priority} \
                 (SCHED_FIFO) refused ({}); its reaction time suffers when other \
                 programs hold every CPU. Run it as the shipped service, or as root, \
                 or give it the right (`setcap cap_sys_nice=ep petrel`, or an \
                 RLIMIT_RTPRIO of {priority}); --no-realtime says not to ask \
                 (docs/run.md, \"On a busy computer\")",
                refusal(e)
            ),
        }
    }
    let asked = short_slice(LOOP_SLICE_NS);
    tracing::debug!("the loop's short scheduling slice: {asked:?}");
    asked
}

/// Why the kernel refused, for people: EPERM and EINVAL by name, others as
/// the system says them.
fn refusal(errno: i32) -> String {
    match errno {
        libc::EPERM => "EPERM: not permitted".into(),
        libc::EINVAL => "EINVAL: not a priority this kernel takes".into(),
        e => std::io::Error::from_raw_os_error(e).to_string(),
    }
}

/// Asks for a short slice (ns) for the calling thread, keeping its policy
/// (normal or batch) and its nice value.
pub fn short_slice(ns: u64) -> Asked {
    imp::change(|attr| {
        if attr.sched_policy != imp::SCHED_OTHER && attr.sched_policy != imp::SCHED_BATCH {
            return false;
        }
        attr.sched_runtime = ns;
        true
    })
}

/// The recorder's writer thread ([`petrel_record::recorder::Options::writer_started`]):
/// its work can wait, so it goes to the batch policy ([`batch`]) and never
/// preempts the gateway's loop.
pub fn recorder_thread() {
    let asked = batch();
    tracing::debug!("the recorder's batch scheduling: {asked:?}");
}

/// Puts the calling thread in the batch policy (its wake-ups preempt no
/// one) with the kernel's default slice (a thread inherits the policy and
/// the slice of the thread that spawned it), keeping its nice value. A
/// thread the crew gave a real-time policy (`chrt -f`, systemd's
/// `CPUSchedulingPolicy=fifo`) goes down to batch too: the loop keeps its
/// real-time priority, the recorder's work never preempts it or the rest
/// of the computer. Lowering a policy needs no privilege; only an idle or
/// deadline thread is left alone.
pub fn batch() -> Asked {
    imp::change(|attr| {
        if ![
            imp::SCHED_OTHER,
            imp::SCHED_BATCH,
            imp::SCHED_FIFO,
            imp::SCHED_RR,
        ]
        .contains(&attr.sched_policy)
        {
            return false;
        }
        attr.sched_policy = imp::SCHED_BATCH;
        attr.sched_priority = 0;
        attr.sched_runtime = 0;
        true
    })
}

/// Puts the calling thread in the normal policy if it runs under a
/// real-time one, and drops any slice of its own, keeping its nice value
/// (a batch thread stays batch). For the threads whose work can wait but
/// which a person sees (the web monitor), and for the programs the gateway
/// starts ([`in_program`]): none of them inherits a real-time priority the
/// crew gave the gateway, nor the loop's short slice.
pub fn normal() -> Asked {
    imp::change(|attr| {
        match attr.sched_policy {
            imp::SCHED_FIFO | imp::SCHED_RR => attr.sched_policy = imp::SCHED_OTHER,
            imp::SCHED_OTHER | imp::SCHED_BATCH => {}
            _ => return false,
        }
        attr.sched_priority = 0;
        attr.sched_runtime = 0;
        true
    })
}

/// Run in a started program's process between fork and exec
/// (`Command::pre_exec`): [`normal`]. It only makes the `sched_getattr`
/// and `sched_setattr` system calls, allocates nothing, and never fails
/// the start.
pub fn in_program() -> std::io::Result<()> {
    let _ = normal();
    Ok(())
}

#[cfg(target_os = "linux")]
mod imp {
    use super::Asked;

    pub const SCHED_OTHER: u32 = 0;
    pub const SCHED_FIFO: u32 = 1;
    pub const SCHED_RR: u32 = 2;
    pub const SCHED_BATCH: u32 = 3;
    /// Children (threads and processes) start under the normal policy.
    pub const SCHED_FLAG_RESET_ON_FORK: u64 = 1;

    /// `struct sched_attr` (linux/sched/types.h), as of Linux 5.3.
    #[repr(C)]
    #[derive(Debug, Default, Clone, Copy)]
    pub struct SchedAttr {
        pub size: u32,
        pub sched_policy: u32,
        pub sched_flags: u64,
        pub sched_nice: i32,
        pub sched_priority: u32,
        pub sched_runtime: u64,
        pub sched_deadline: u64,
        pub sched_period: u64,
        pub sched_util_min: u32,
        pub sched_util_max: u32,
    }

    const SIZE: u32 = std::mem::size_of::<SchedAttr>() as u32;

    fn errno() -> i32 {
        std::io::Error::last_os_error().raw_os_error().unwrap_or(0)
    }

    /// Reads the calling thread's attributes, lets `edit` change them (it
    /// says whether to), and sets them.
    pub fn change(edit: impl FnOnce(&mut SchedAttr) -> bool) -> Asked {
        let mut attr = match get() {
            Ok(attr) => attr,
            Err(e) => return Asked::Refused(e),
        };
        // Utilisation clamps are set only when their flag says so.
        attr.size = SIZE;
        attr.sched_flags = 0;
        if !edit(&mut attr) {
            return Asked::LeftAlone;
        }
        // SAFETY: sched_setattr(0, attr, 0) reads `attr.size` bytes from
        // `attr`, which is that large and lives across the call.
        let set =
            unsafe { libc::syscall(libc::SYS_sched_setattr, 0, &attr as *const SchedAttr, 0) };
        if set != 0 {
            return Asked::Refused(errno());
        }
        Asked::Granted
    }

    /// The calling thread's attributes, or the error number. Makes one
    /// system call and allocates nothing (it runs between fork and exec).
    fn get() -> Result<SchedAttr, i32> {
        let mut attr = SchedAttr::default();
        // SAFETY: sched_getattr(0, attr, size, 0) writes at most `size`
        // bytes into `attr`, which is that large and lives across the call.
        let got = unsafe {
            libc::syscall(
                libc::SYS_sched_getattr,
                0,
                &mut attr as *mut SchedAttr,
                SIZE,
                0,
            )
        };
        if got != 0 {
            return Err(errno());
        }
        Ok(attr)
    }

    /// The calling thread's attributes (tests).
    #[cfg(test)]
    pub fn current() -> Option<SchedAttr> {
        get().ok()
    }
}

#[cfg(not(target_os = "linux"))]
mod imp {
    use super::Asked;

    pub const SCHED_OTHER: u32 = 0;
    pub const SCHED_FIFO: u32 = 1;
    pub const SCHED_RR: u32 = 2;
    pub const SCHED_BATCH: u32 = 3;
    pub const SCHED_FLAG_RESET_ON_FORK: u64 = 1;

    pub struct SchedAttr {
        pub sched_policy: u32,
        pub sched_flags: u64,
        pub sched_priority: u32,
        pub sched_runtime: u64,
    }

    pub fn change(_: impl FnOnce(&mut SchedAttr) -> bool) -> Asked {
        Asked::Refused(0)
    }
}

#[cfg(all(test, target_os = "linux"))]
mod tests {
    use super::*;

    /// Each test on a thread of its own: the attributes are the thread's.
    fn on_thread<T: Send + 'static>(f: impl FnOnce() -> T + Send + 'static) -> T {
        std::thread::spawn(f).join().expect("the test thread")
    }

    #[test]
    fn a_short_slice_is_granted_and_keeps_the_policy_and_nice_value() {
        let (asked, before, after) = on_thread(|| {
            let before = imp::current().expect("sched_getattr");
            let asked = short_slice(LOOP_SLICE_NS);
            (asked, before, imp::current().expect("sched_getattr"))
        });
        assert_eq!(after.sched_policy, before.sched_policy);
        assert_eq!(after.sched_nice, before.sched_nice);
        match asked {
            // Kernels before 6.12 accept the call and keep their own slice.
            Asked::Granted => assert!(
                after.sched_runtime == LOOP_SLICE_NS || after.sched_runtime == before.sched_runtime,
                "{after:?}"
            ),
            Asked::LeftAlone => assert!(before.sched_policy != imp::SCHED_OTHER),
            Asked::Refused(e) => panic!("refused: errno {e}"),
        }
    }

    #[test]
    fn the_batch_policy_is_granted_and_keeps_the_nice_value() {
        let (asked, before, after) = on_thread(|| {
            let before = imp::current().expect("sched_getattr");
            let asked = batch();
            (asked, before, imp::current().expect("sched_getattr"))
        });
        assert_eq!(after.sched_nice, before.sched_nice);
        match asked {
            Asked::Granted => assert_eq!(after.sched_policy, imp::SCHED_BATCH),
            Asked::LeftAlone => {
                assert_eq!(after.sched_policy, before.sched_policy);
                assert!(before.sched_policy > imp::SCHED_BATCH, "{before:?}");
            }
            Asked::Refused(e) => panic!("refused: errno {e}"),
        }
    }

    #[test]
    fn a_thread_put_in_batch_drops_the_short_slice_it_inherited() {
        let (parent, child) = on_thread(|| {
            assert_eq!(short_slice(LOOP_SLICE_NS), Asked::Granted);
            let parent = imp::current().expect("sched_getattr");
            let child = on_thread(|| {
                assert_eq!(batch(), Asked::Granted);
                imp::current().expect("sched_getattr")
            });
            (parent, child)
        });
        assert_eq!(child.sched_policy, imp::SCHED_BATCH);
        // On kernels that keep a slice of a thread's own (6.12 and later).
        if parent.sched_runtime == LOOP_SLICE_NS {
            assert_ne!(child.sched_runtime, LOOP_SLICE_NS, "{child:?}");
        }
    }

    /// Raises the calling thread to SCHED_FIFO 1; false without the
    /// privilege to (the test is then skipped).
    fn raise_to_fifo() -> bool {
        imp::change(|attr| {
            attr.sched_policy = imp::SCHED_FIFO;
            attr.sched_priority = 1;
            attr.sched_runtime = 0;
            true
        }) == Asked::Granted
    }

    #[test]
    fn a_real_time_thread_goes_down_to_batch() {
        let after = on_thread(|| {
            if !raise_to_fifo() {
                return None;
            }
            assert_eq!(batch(), Asked::Granted);
            imp::current()
        });
        if let Some(after) = after {
            assert_eq!(after.sched_policy, imp::SCHED_BATCH);
            assert_eq!(after.sched_priority, 0);
        }
    }

    #[test]
    fn a_real_time_thread_goes_down_to_normal_and_its_programs_start_normal() {
        let got = on_thread(|| {
            if !raise_to_fifo() {
                return None;
            }
            // A program started from the real-time thread: its policy is
            // field 41 of /proc/self/stat.
            let mut command = std::process::Command::new("cat");
            command.arg("/proc/self/stat");
            // SAFETY: in_program makes two system calls and allocates nothing.
            unsafe {
                std::os::unix::process::CommandExt::pre_exec(&mut command, in_program);
            }
            let out = command.output().expect("cat");
            let stat = String::from_utf8_lossy(&out.stdout).to_string();
            assert_eq!(normal(), Asked::Granted);
            Some((imp::current(), stat))
        });
        let Some((after, stat)) = got else {
            println!("skipped: raising a thread to a real-time policy needs privileges");
            return;
        };
        let after = after.expect("sched_getattr");
        assert_eq!(
            (after.sched_policy, after.sched_priority),
            (imp::SCHED_OTHER, 0)
        );
        let fields: Vec<&str> = stat[stat.rfind(')').expect("a stat line") + 2..]
            .split_whitespace()
            .collect();
        // Field 41 is the 39th after the command's name and state.
        assert_eq!(fields.get(38), Some(&"0"), "the program's policy: {stat}");
    }

    #[test]
    fn a_normal_thread_drops_its_own_slice_and_keeps_its_policy() {
        let after = on_thread(|| {
            assert_eq!(short_slice(LOOP_SLICE_NS), Asked::Granted);
            assert_eq!(normal(), Asked::Granted);
            imp::current().expect("sched_getattr")
        });
        assert_eq!(after.sched_policy, imp::SCHED_OTHER);
        assert_ne!(after.sched_runtime, LOOP_SLICE_NS);
    }

    #[test]
    fn a_thread_in_batch_keeps_it_when_given_a_slice() {
        let after = on_thread(|| {
            assert_eq!(batch(), Asked::Granted);
            assert_eq!(short_slice(LOOP_SLICE_NS), Asked::Granted);
            imp::current().expect("sched_getattr")
        });
        assert_eq!(after.sched_policy, imp::SCHED_BATCH);
    }

    #[test]
    fn real_time_is_granted_with_reset_on_fork_and_a_thread_it_starts_runs_normal() {
        let got = on_thread(|| {
            let asked = real_time(LOOP_PRIORITY);
            let me = imp::current().expect("sched_getattr");
            let child = on_thread(|| imp::current().expect("sched_getattr"));
            (asked, me, child)
        });
        match got {
            (Asked::Granted, me, child) => {
                assert_eq!(
                    (me.sched_policy, me.sched_priority),
                    (imp::SCHED_FIFO, LOOP_PRIORITY)
                );
                assert_ne!(me.sched_flags & imp::SCHED_FLAG_RESET_ON_FORK, 0, "{me:?}");
                assert_eq!(
                    (child.sched_policy, child.sched_priority),
                    (imp::SCHED_OTHER, 0),
                    "{child:?}"
                );
            }
            (Asked::Refused(e), me, _) => {
                println!("skipped: a real-time policy needs privileges (errno {e})");
                assert_ne!(me.sched_policy, imp::SCHED_FIFO);
            }
            (Asked::LeftAlone, me, _) => {
                assert!(me.sched_policy > imp::SCHED_BATCH, "{me:?}")
            }
        }
    }

    #[test]
    fn a_real_time_policy_given_from_outside_is_kept() {
        let after = on_thread(|| {
            if !raise_to_fifo() {
                return None;
            }
            Some((real_time(LOOP_PRIORITY), imp::current()))
        });
        if let Some((asked, after)) = after {
            assert_eq!(asked, Asked::LeftAlone);
            let after = after.expect("sched_getattr");
            assert_eq!(
                (after.sched_policy, after.sched_priority),
                (imp::SCHED_FIFO, 1)
            );
        }
    }

    #[test]
    fn a_refused_priority_leaves_the_loop_normal_with_a_short_slice() {
        // 100 is no priority: the kernel refuses it whatever the privileges.
        let (refused, fell_back, after) = on_thread(|| {
            let refused = real_time(100);
            let fell_back = for_the_loop(Some(100));
            (refused, fell_back, imp::current().expect("sched_getattr"))
        });
        assert!(matches!(refused, Asked::Refused(_)), "{refused:?}");
        assert_eq!(fell_back, Asked::Granted, "the short slice");
        assert_eq!(
            (after.sched_policy, after.sched_priority),
            (imp::SCHED_OTHER, 0)
        );
    }

    #[test]
    fn no_priority_asked_keeps_the_normal_policy() {
        let after = on_thread(|| {
            assert_eq!(for_the_loop(None), Asked::Granted);
            imp::current().expect("sched_getattr")
        });
        assert_eq!(
            (after.sched_policy, after.sched_priority),
            (imp::SCHED_OTHER, 0)
        );
    }
}
