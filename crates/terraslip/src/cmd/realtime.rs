//! Real-time scheduling for the thread that answers velocity commands, as
//! ros2_control's controller_manager asks it for its update loop: the
//! thread asks for `SCHED_FIFO` at a priority; when the system does not
//! permit it, it says once what to change and runs at normal priority.

use std::fmt::Display;

use thread_priority::{
    set_thread_priority_and_policy, thread_native_id, RealtimeThreadSchedulePolicy, ThreadPriority,
    ThreadPriorityValue, ThreadSchedulePolicy,
};

/// Default `SCHED_FIFO` priority of the command thread (ros2_control's
/// controller_manager's `thread_priority`).
pub const DEFAULT_PRIORITY: u8 = 50;

/// Highest `SCHED_FIFO` priority on Linux.
pub const MAX_PRIORITY: u8 = 99;

/// How the calling thread is scheduled after [`request`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Scheduling {
    /// `SCHED_FIFO` at this priority.
    Fifo(u8),
    /// Normal priority: not asked for (priority 0).
    NotAsked,
    /// Normal priority: `SCHED_FIFO` refused, with what to change.
    Refused(String),
}

impl Scheduling {
    /// A short phrase for diagnostics.
    pub fn describe(&self) -> String {
        match self {
            Self::Fifo(p) => format!("SCHED_FIFO {p}"),
            Self::NotAsked => "normal (thread_priority 0)".into(),
            Self::Refused(_) => "normal (SCHED_FIFO refused)".into(),
        }
    }
}

/// Asks `SCHED_FIFO` at `priority` (1..=99) for the calling thread; 0 asks
/// nothing.
pub fn request(priority: u8) -> Scheduling {
    if priority == 0 {
        return Scheduling::NotAsked;
    }
    let asked = ThreadPriorityValue::try_from(priority.min(MAX_PRIORITY))
        .map_err(|e| e.to_string())
        .and_then(|v| {
            set_thread_priority_and_policy(
                thread_native_id(),
                ThreadPriority::Crossplatform(v),
                ThreadSchedulePolicy::Realtime(RealtimeThreadSchedulePolicy::Fifo),
            )
            .map_err(|e| e.to_string())
        });
    outcome(priority, asked)
}

/// What asking for `priority` came to (`asked`: the system's answer).
fn outcome(priority: u8, asked: Result<(), impl Display>) -> Scheduling {
    match asked {
        Ok(()) => Scheduling::Fifo(priority),
        Err(e) => Scheduling::Refused(format!(
            "warning: the command thread runs at normal priority: SCHED_FIFO {priority} refused \
             ({e}); on a loaded machine answers may then wait tens of ms for a CPU. To permit it, \
             give the user a real-time limit (a line `USER - rtprio 99` in \
             /etc/security/limits.conf, then log in again), or start the node under \
             `chrt -f {priority}`; --thread-priority 0 stops asking"
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_refusal_says_how_to_permit_it_and_zero_asks_nothing() {
        // EPERM, as for a user without an rtprio limit.
        let s = outcome(50, Err("the operating system returned error code 1"));
        let Scheduling::Refused(why) = &s else {
            panic!("{s:?}")
        };
        for part in [
            "SCHED_FIFO 50",
            "error code 1",
            "rtprio",
            "limits.conf",
            "chrt -f 50",
        ] {
            assert!(why.contains(part), "{part}: {why}");
        }
        assert_eq!(s.describe(), "normal (SCHED_FIFO refused)");
        assert_eq!(outcome(50, Ok::<(), &str>(())), Scheduling::Fifo(50));
        assert_eq!(request(0), Scheduling::NotAsked);
    }

    /// Run in a thread of its own: whatever the system answers, the
    /// thread goes on (as root or with an rtprio limit it is granted).
    #[test]
    fn asking_never_fails_the_thread() {
        let got = std::thread::spawn(|| request(DEFAULT_PRIORITY))
            .join()
            .unwrap();
        assert!(
            matches!(got, Scheduling::Fifo(50) | Scheduling::Refused(_)),
            "{got:?}"
        );
    }
}
