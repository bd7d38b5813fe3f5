//! The launcher's library: what its commands share with each other and with integration
//! tests — a stack for your own publisher's tests ([`harness`]), the service settings of a run ([`settings`]), the processes of a
//! stack and who waits for whom ([`topology`]), the estimators a comparison runs
//! ([`methods`]) and the in-process pipeline of the Monte Carlo comparison ([`offline`]), and children that die
//! with their parent ([`children`]).

pub mod children;
pub mod harness;
pub mod lists;
pub mod methods;
pub mod offline;
pub mod settings;
pub mod topology;

/// A stack prefix of this launcher's own (`run` and `replay` without `--prefix`), so
/// parallel runs never see each other.
pub fn fresh_prefix() -> String {
    format!("fs{}x", std::process::id())
}

/// The lock file a launcher holds (an exclusive `flock`) while its stack on `prefix`
/// runs, whatever the stack's iceoryx2 root: one stack per prefix.
pub fn stack_lock(prefix: &str) -> std::path::PathBuf {
    std::env::temp_dir()
        .join("fsl")
        .join(format!("{prefix}.lock"))
}

/// The iceoryx2 root directory the launcher gives the stack `prefix`: its own, so it
/// goes with the stack, and short, since it holds Unix sockets.
pub fn stack_root(prefix: &str) -> std::path::PathBuf {
    std::env::temp_dir().join("fsl").join(prefix)
}
