//! Where a stack lives: its prefix and iceoryx2 root ([`StackConfig`], whose checks turn
//! them into an iceoryx2 configuration), and the files a stack leaves behind in
//! `/dev/shm` and in its root.

use super::{IpcError, Result};
use iceoryx2::prelude::*;

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
