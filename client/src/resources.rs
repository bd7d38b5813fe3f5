//! CPU time and peak memory of every process of the stack, read from `/proc`.
//!
//! The processes are found through iceoryx2 itself: `Node::list` under the stack's
//! configuration names every node with its process id, so the client needs no help from
//! the launcher and also measures the stack's processes a user started by hand. Only the
//! stack's own processes count, told by their node names (`ipc::STACK_NODES`): a process
//! of one's own that joins the stack (a viewer, a publisher) is not measured. Each process is
//! sampled while it runs (the client calls [`ProcessMonitor::sample`] on a timer and when
//! a stream ends) and its last sample stands after it exits: a process has done its work
//! once it has announced the end of its stream, so the final sample misses only its
//! teardown. The total CPU time comes from `/proc/<pid>/task/*/schedstat` (the
//! scheduler's run time of every thread, in ns); the user/kernel split from
//! `/proc/<pid>/stat` is in clock ticks (usually 10 ms).

use fastslam_protocol::ipc::{Ipc, Service, is_stack_node};
use iceoryx2::node::{NodeState, NodeView};
use iceoryx2::prelude::{CallbackProgression, Node};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// CPU time and peak memory of one process.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ProcessUsage {
    /// The iceoryx2 node name (the process's role: `fastslam-service`, `truth-sim`, …).
    pub name: String,
    /// Process id.
    pub pid: i32,
    /// CPU time in user mode (s).
    #[serde(deserialize_with = "crate::json_number::number")]
    pub cpu_user_s: f64,
    /// CPU time in the kernel on the process's behalf (s).
    #[serde(deserialize_with = "crate::json_number::number")]
    pub cpu_system_s: f64,
    /// Total CPU time (s): the scheduler's run time summed over the process's threads
    /// (`schedstat`, ns resolution), or user plus system time (clock ticks, exited threads
    /// included) when that is larger or `schedstat` is not available.
    #[serde(deserialize_with = "crate::json_number::number")]
    pub cpu_s: f64,
    /// Peak resident set size, `VmHWM` (MiB). Shared-memory pages the process touched
    /// count too, so the sum over processes counts shared pages more than once.
    #[serde(deserialize_with = "crate::json_number::number")]
    pub peak_rss_mib: f64,
}

/// One reading of `/proc/<pid>/stat` and `/proc/<pid>/status`.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Reading {
    /// Start time since boot (clock ticks): tells a reused pid from the original process.
    started: u64,
    user_ticks: u64,
    system_ticks: u64,
    /// Time on a CPU (ns), from `schedstat`.
    runtime_ns: Option<u64>,
    peak_rss_kib: Option<u64>,
}

/// Finds the processes of a stack and keeps their latest readings.
pub struct ProcessMonitor {
    processes: BTreeMap<i32, (String, Reading)>,
    ticks_per_s: f64,
}

impl ProcessMonitor {
    /// A monitor with no processes yet; [`ProcessMonitor::sample`] finds them.
    pub fn new() -> Self {
        let ticks = nix::unistd::sysconf(nix::unistd::SysconfVar::CLK_TCK)
            .ok()
            .flatten()
            .filter(|&t| t > 0)
            .unwrap_or(100);
        Self {
            processes: BTreeMap::new(),
            ticks_per_s: ticks as f64,
        }
    }

    /// Looks for new nodes of the stack `ipc` belongs to, then reads every known process
    /// that is still running. A process that has exited keeps its last reading.
    pub fn sample(&mut self, ipc: &Ipc) {
        let mut found = Vec::new();
        let listed = Node::<Service>::list(ipc.node().config(), |state| {
            if let NodeState::Alive(view) = state
                && let Some(details) = view.details()
                && is_stack_node(details.name().as_str())
            {
                found.push((
                    details.process_id().value(),
                    details.name().as_str().to_string(),
                ));
            }
            CallbackProgression::Continue
        });
        if let Err(e) = listed {
            tracing::debug!(?e, "listing the stack's nodes failed");
        }
        for (pid, name) in found {
            if let (false, Some(r)) = (self.processes.contains_key(&pid), read(pid)) {
                self.processes.insert(pid, (name, r));
            }
        }
        for (pid, (_, last)) in &mut self.processes {
            match read(*pid) {
                // A live process with the same start time is the same process.
                Some(r) if r.started == last.started => {
                    *last = Reading {
                        runtime_ns: r.runtime_ns.or(last.runtime_ns),
                        peak_rss_kib: r.peak_rss_kib.or(last.peak_rss_kib),
                        ..r
                    }
                }
                _ => {}
            }
        }
    }

    /// The usage of every process seen, in pid order.
    pub fn usage(&self) -> Vec<ProcessUsage> {
        self.processes
            .iter()
            .map(|(&pid, (name, r))| {
                let user = r.user_ticks as f64 / self.ticks_per_s;
                let system = r.system_ticks as f64 / self.ticks_per_s;
                ProcessUsage {
                    name: name.clone(),
                    pid,
                    cpu_user_s: user,
                    cpu_system_s: system,
                    cpu_s: r
                        .runtime_ns
                        .map_or(user + system, |ns| (ns as f64 * 1e-9).max(user + system)),
                    peak_rss_mib: r.peak_rss_kib.map_or(f64::NAN, |k| k as f64 / 1024.0),
                }
            })
            .collect()
    }
}

impl Default for ProcessMonitor {
    fn default() -> Self {
        Self::new()
    }
}

/// Reads a process's CPU times, start time and peak memory; `None` once it is gone.
fn read(pid: i32) -> Option<Reading> {
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).ok()?;
    let status = std::fs::read_to_string(format!("/proc/{pid}/status")).ok();
    let mut r = parse(&stat, status.as_deref())?;
    r.runtime_ns = threads_runtime_ns(pid);
    Some(r)
}

/// Time on a CPU (ns) summed over the process's threads: `/proc/<pid>/schedstat` alone
/// is its main thread's (a filter's rayon workers would be missed). `None` where the
/// kernel keeps no schedstat. Threads that have exited are not counted; the tick-based
/// user and system times are, which is why [`ProcessUsage::cpu_s`] takes the larger.
fn threads_runtime_ns(pid: i32) -> Option<u64> {
    let tasks = std::fs::read_dir(format!("/proc/{pid}/task")).ok()?;
    let mut total = None;
    for task in tasks.flatten() {
        // `schedstat`: time on a CPU (ns), time waiting for one (ns), timeslices.
        let ns = std::fs::read_to_string(task.path().join("schedstat"))
            .ok()
            .and_then(|s| s.split_whitespace().next()?.parse::<u64>().ok());
        if let Some(ns) = ns {
            total = Some(total.unwrap_or(0) + ns);
        }
    }
    total
}

/// Parses `/proc/<pid>/stat` (fields 14, 15 and 22: utime, stime, starttime, counted
/// after the parenthesised command name, which may itself contain spaces) and the
/// `VmHWM` line of `/proc/<pid>/status` (absent for a zombie).
fn parse(stat: &str, status: Option<&str>) -> Option<Reading> {
    let after_name = &stat[stat.rfind(')')? + 1..];
    // `after_name` starts at field 3 (state).
    let fields: Vec<&str> = after_name.split_whitespace().collect();
    let field = |n: usize| fields.get(n - 3)?.parse::<u64>().ok();
    let peak_rss_kib = status.and_then(|s| {
        s.lines()
            .find_map(|l| l.strip_prefix("VmHWM:"))
            .and_then(|v| v.trim().trim_end_matches("kB").trim().parse().ok())
    });
    Some(Reading {
        started: field(22)?,
        user_ticks: field(14)?,
        system_ticks: field(15)?,
        runtime_ns: None,
        peak_rss_kib,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stat_fields_are_counted_after_a_command_name_with_spaces() {
        let stat = "4242 (my (odd) name) S 1 4242 4242 0 -1 4194560 500 0 0 0 \
                    250 30 0 0 20 0 3 0 987654 1000000 300 18446744073709551615";
        let status = "Name:\tx\nVmPeak:\t  9000 kB\nVmHWM:\t    2048 kB\nVmRSS:\t 1000 kB\n";
        let r = parse(stat, Some(status)).unwrap();
        assert_eq!(
            (r.user_ticks, r.system_ticks, r.started, r.peak_rss_kib),
            (250, 30, 987654, Some(2048))
        );
        assert_eq!(parse(stat, None).unwrap().peak_rss_kib, None);
        assert_eq!(parse("garbage", None), None);
    }

    #[test]
    fn cpu_time_of_every_thread_is_counted() {
        if !std::path::Path::new("/proc/thread-self/schedstat").exists() {
            return;
        }
        // A second thread burns 200 ms of its own CPU time (by its own schedstat) and
        // stays alive while the process is read.
        let own_ns = || {
            let s = std::fs::read_to_string("/proc/thread-self/schedstat").unwrap();
            s.split_whitespace().next().unwrap().parse::<u64>().unwrap()
        };
        let (burnt, read_done) = (std::sync::mpsc::channel(), std::sync::mpsc::channel());
        let (tell, wait_burnt) = burnt;
        let (done, wait_read) = read_done;
        let worker = std::thread::spawn(move || {
            let start = own_ns();
            while own_ns() - start < 200_000_000 {
                std::hint::black_box(start);
            }
            tell.send(()).unwrap();
            wait_read.recv().unwrap();
        });
        wait_burnt.recv().unwrap();
        let r = read(std::process::id() as i32).unwrap();
        done.send(()).unwrap();
        worker.join().unwrap();
        assert!(r.runtime_ns.unwrap() >= 200_000_000, "{r:?}");
    }

    #[test]
    fn this_process_can_be_read_and_uses_memory() {
        let r = read(std::process::id() as i32).unwrap();
        assert!(r.peak_rss_kib.unwrap() > 0);
        assert!(r.started > 0);
        if std::path::Path::new("/proc/self/schedstat").exists() {
            assert!(r.runtime_ns.unwrap() > 0, "this test ran on a CPU");
        }
    }
}
