//! What the IPC tests share: a stack of their own, a thread that runs a test on it, and
//! the ports they send on.

use super::{Ipc, Pub, Result, StackConfig, Sub, remove_stack_files};
use crate::EndOfStream;
use crate::topics;
use std::time::Duration;

/// A stack of its own for one test: prefix and root, removed by [`TestStack::drop`].
pub(super) struct TestStack {
    prefix: String,
    root: std::path::PathBuf,
}

impl TestStack {
    pub(super) fn new(tag: &str) -> Self {
        let prefix = format!("{tag}{}x", std::process::id());
        let root = std::env::temp_dir().join("fsl").join(&prefix);
        Self { prefix, root }
    }

    pub(super) fn config(&self) -> StackConfig {
        StackConfig {
            prefix: self.prefix.clone(),
            root: Some(self.root.display().to_string()),
        }
    }
}

/// Runs `test` with an `Ipc` on `stack` on a thread of its own and returns what it
/// returned (errors as text); fails with `hang` if it has not returned within 10 s. Its
/// node takes the name of one of the stack's processes (`client`), so publishers wait for
/// its subscribers.
pub(super) fn on_thread<T: Send + 'static>(
    stack: StackConfig,
    hang: &str,
    test: impl FnOnce(&Ipc) -> Result<T> + Send + 'static,
) -> std::result::Result<T, String> {
    let (done, result) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let run = || test(&Ipc::open(&stack, "client", Duration::from_secs(5))?);
        let _ = done.send(run().map_err(|e| e.to_string()));
    });
    result.recv_timeout(Duration::from_secs(10)).expect(hang)
}

/// A publisher and a subscriber of the end-of-stream topic, the topic these tests
/// send on (the publisher first: a subscriber waits for one).
pub(super) fn eos_ports(ipc: &Ipc) -> Result<(Pub<EndOfStream, ()>, Sub<EndOfStream, ()>)> {
    let out = ipc.publisher::<EndOfStream>(&topics::END_OF_STREAM)?;
    Ok((out, ipc.subscriber::<EndOfStream>(&topics::END_OF_STREAM)?))
}

impl Drop for TestStack {
    fn drop(&mut self) {
        remove_stack_files(&self.prefix, Some(&self.root));
    }
}
