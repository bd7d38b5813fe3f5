//! Where a stack lives: its prefix and iceoryx2 root ([`StackConfig`], whose checks turn
//! them into an iceoryx2 configuration), and the files a stack leaves behind in
//! `/dev/shm` and in its root.

use super::{IpcError, Result, Service, iox_err};
use iceoryx2::prelude::*;
use std::os::unix::fs::PermissionsExt;

/// The files in `/dev/shm` of the stack with `prefix` (its iceoryx2 file prefix): a stack
/// with a live node always has some.
pub fn shared_memory_files(prefix: &str) -> Vec<std::path::PathBuf> {
    let Ok(entries) = std::fs::read_dir("/dev/shm") else {
        return Vec::new();
    };
    entries
        .flatten()
        .filter(|e| e.file_name().to_string_lossy().starts_with(prefix))
        .map(|e| e.path())
        .collect()
}

/// Removes what is left of the stack with `prefix` once its processes are gone: its
/// shared-memory files and, when it has one of its own, its iceoryx2 `root` directory.
/// Best effort: a file that cannot be removed stays.
pub fn remove_stack_files(prefix: &str, root: Option<&std::path::Path>) {
    for file in shared_memory_files(prefix) {
        let _ = std::fs::remove_file(file);
    }
    if let Some(root) = root {
        let _ = std::fs::remove_dir_all(root);
    }
}

/// Removes what the nodes of `stack` whose processes died (SIGKILL, a crash) left
/// behind: their node entries and the ports they held, so services the dead nodes
/// created are gone once no live node uses them. Live nodes are untouched. First removes
/// the segments a process was killed while making (`remove_unfinished_segments`), on
/// which iceoryx2's clean-up would wait for ever. Returns how many dead nodes were cleaned.
///
/// # Errors
/// [`IpcError::InvalidLocation`] for a bad prefix/root, [`IpcError::Iceoryx`] when the
/// nodes cannot be listed.
pub fn remove_dead_nodes(stack: &StackConfig) -> Result<usize> {
    let config = stack.iceoryx_config()?;
    let unfinished = remove_unfinished_segments(&stack.prefix);
    if unfinished > 0 {
        tracing::info!(
            unfinished,
            prefix = stack.prefix,
            "removed shared-memory segments a killed process left half made"
        );
    }
    let mut removed = 0;
    Node::<Service>::list(&config, |state| {
        if let NodeState::Dead(view) = state {
            match view.try_remove_stale_resources() {
                Ok(()) => removed += 1,
                Err(e) => tracing::warn!(error = ?e, "cannot clean up a dead node"),
            }
        }
        CallbackProgression::Continue
    })
    .map_err(iox_err(format!("list the nodes of stack {}", stack.prefix)))?;
    Ok(removed)
}

/// Removes the stack's shared-memory segments whose creation a kill interrupted: empty
/// and not yet readable by their owner (iceoryx2 makes a segment readable once it is
/// initialised) for a second or more. iceoryx2's clean-up of a dead node waits without end
/// for such a segment to grow. A live process initialises a segment within microseconds,
/// so a younger one is watched until it is finished (and kept) or has been left that long
/// (and removed): the call returns within about a second, and is safe while other
/// processes of the stack run. Returns how many segments it removed.
fn remove_unfinished_segments(prefix: &str) -> usize {
    let deadline = std::time::Instant::now() + UNFINISHED_AGE + UNFINISHED_POLL;
    let mut removed = 0;
    loop {
        let mut young = false;
        for file in shared_memory_files(prefix) {
            match unfinished_for(&file) {
                Some(idle) if idle >= UNFINISHED_AGE => {
                    removed += usize::from(std::fs::remove_file(&file).is_ok());
                }
                Some(_) => young = true,
                None => {}
            }
        }
        if !young || std::time::Instant::now() >= deadline {
            return removed;
        }
        std::thread::sleep(UNFINISHED_POLL);
    }
}

/// How long `file` has been left empty and unreadable by its owner; `None` when it is
/// not (or is gone). A modification time in the future counts as just now.
fn unfinished_for(file: &std::path::Path) -> Option<std::time::Duration> {
    let m = std::fs::metadata(file).ok()?;
    let unfinished = m.len() == 0 && m.permissions().mode() & 0o400 == 0;
    unfinished.then(|| {
        let idle = m.modified().ok().and_then(|t| t.elapsed().ok());
        idle.unwrap_or_default()
    })
}

/// How long an empty, unreadable segment must have been left before it counts as
/// unfinished: a live process initialises one within microseconds.
const UNFINISHED_AGE: std::time::Duration = std::time::Duration::from_secs(1);

/// How often a young unfinished segment is looked at again.
const UNFINISHED_POLL: std::time::Duration = std::time::Duration::from_millis(50);

/// Makes the stack's node-management file in `/dev/shm`, which iceoryx2 creates
/// readable and writable by everyone, the owner's alone (0600), as every other file of a
/// stack is. Best effort: a file of another user's stays as it is.
pub(super) fn make_management_file_private(prefix: &str) {
    for file in shared_memory_files(prefix) {
        let shared = std::fs::metadata(&file).is_ok_and(|m| m.permissions().mode() & 0o077 != 0);
        if shared && file.to_string_lossy().ends_with(".global_mgmt") {
            let _ = std::fs::set_permissions(&file, std::fs::Permissions::from_mode(0o600));
        }
    }
}

/// Where a stack lives. The prefix is used twice: as iceoryx2's file prefix (so
/// `/dev/shm/<prefix>*` belongs to this stack alone) and as the service-name prefix.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct StackConfig {
    /// Stack name: letters, digits, `_` and `-` only.
    pub prefix: String,
    /// iceoryx2 root directory (Unix sockets live here; keep it short). `None`: the
    /// iceoryx2 default.
    pub root: Option<String>,
}

impl StackConfig {
    /// The iceoryx2 configuration of this stack.
    ///
    /// # Errors
    /// [`IpcError::InvalidLocation`] when the prefix or root is not a valid file name/path.
    pub fn iceoryx_config(&self) -> Result<Config> {
        let invalid = |value: &str, reason: &str| IpcError::InvalidLocation {
            value: value.to_string(),
            reason: reason.to_string(),
        };
        let ok_char = |c: char| c.is_ascii_alphanumeric() || c == '_' || c == '-';
        if self.prefix.is_empty() || self.prefix.len() > 32 || !self.prefix.chars().all(ok_char) {
            return Err(invalid(&self.prefix, "use 1–32 of [A-Za-z0-9_-]"));
        }
        let mut config = Config::default();
        config.global.prefix = FileName::new(self.prefix.as_bytes())
            .map_err(|e| invalid(&self.prefix, &format!("{e:?}")))?;
        if let Some(root) = &self.root {
            let path = Path::new(root.as_bytes()).map_err(|e| invalid(root, &format!("{e:?}")))?;
            config.global.set_root_path(&path);
        }
        Ok(config)
    }
}

#[cfg(test)]
mod tests {
    use super::super::testing::{TestStack, eos_ports, on_thread};
    use super::*;

    #[test]
    fn only_empty_unreadable_segments_left_for_a_second_are_unfinished() {
        let prefix = format!("unfin{}", std::process::id());
        let old = std::time::SystemTime::now() - 2 * UNFINISHED_AGE;
        let make = |name: &str, mode: u32, bytes: &[u8], modified| {
            let path = std::path::Path::new("/dev/shm").join(format!("{prefix}{name}"));
            std::fs::write(&path, bytes).unwrap();
            std::fs::set_permissions(&path, std::fs::Permissions::from_mode(mode)).unwrap();
            std::fs::File::options()
                .write(true)
                .open(&path)
                .unwrap()
                .set_modified(modified)
                .unwrap();
            path
        };
        let now = std::time::SystemTime::now();
        let killed = make("_a.connection", 0o200, b"", old);
        let killed_young = make("_e.connection", 0o200, b"", now);
        let kept = [
            make("_b.connection", 0o600, b"", old),
            make("_c.connection", 0o200, b"x", old),
            make("_d.connection", 0o200, b"", now),
        ];
        // A live maker finishes its young segment while the clean-up watches it.
        let finishing = kept[2].clone();
        let maker = std::thread::spawn(move || {
            std::thread::sleep(UNFINISHED_AGE / 4);
            std::fs::set_permissions(&finishing, std::fs::Permissions::from_mode(0o600)).unwrap();
        });
        assert_eq!(remove_unfinished_segments(&prefix), 2);
        maker.join().unwrap();
        assert!(!killed.exists() && !killed_young.exists());
        for file in &kept {
            assert!(file.exists(), "{} was removed", file.display());
        }
        remove_stack_files(&prefix, None);
    }

    #[test]
    fn no_file_of_a_stack_in_dev_shm_is_shared_with_other_users() {
        let stack = TestStack::new("perm");
        let prefix = stack.config().prefix;
        let modes = on_thread(stack.config(), "opening ports hangs", move |ipc| {
            let _ports = eos_ports(ipc)?;
            Ok(shared_memory_files(&prefix)
                .into_iter()
                .map(|f| (std::fs::metadata(&f).map(|m| m.permissions().mode()), f))
                .collect::<Vec<_>>())
        })
        .unwrap();
        assert!(
            modes
                .iter()
                .any(|(_, f)| f.to_string_lossy().ends_with(".global_mgmt")),
            "the stack's node-management file is among {modes:?}"
        );
        for (mode, file) in &modes {
            let mode = mode.as_ref().expect("a file of the stack");
            assert_eq!(mode & 0o077, 0, "{} is mode {mode:o}", file.display());
        }
    }
}
