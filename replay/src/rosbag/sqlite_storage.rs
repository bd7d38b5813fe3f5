//! SQLite storage files (`.db3`, rosbag2's default storage before ROS 2 Iron): a `topics`
//! table (id, name, type, serialization format) and a `messages` table (topic id, receive
//! time in ns, serialised bytes), read in time order. The database is opened read-only;
//! a file that is not a database, or lacks the tables, is an error naming it.

use super::storage::Collector;
use crate::text::{DataError, Result};
use rusqlite::{Connection, OpenFlags};
use std::collections::HashMap;
use std::path::Path;

/// Reads the database at `db` into `sink`; errors name `shown` (the bag's file, which
/// differs from `db` when that is a decompressed copy).
///
/// # Errors
/// [`DataError::Io`] when the file is not a readable rosbag2 database, a message refers
/// to an unknown topic or has a negative time.
pub fn read(db: &Path, shown: &Path, sink: &mut Collector) -> Result<()> {
    let bad = |reason: String| DataError::Io {
        path: shown.to_path_buf(),
        reason,
    };
    let sql = |e: rusqlite::Error| bad(format!("not a readable rosbag2 database: {e}"));
    let flags = OpenFlags::SQLITE_OPEN_READ_ONLY | OpenFlags::SQLITE_OPEN_NO_MUTEX;
    let conn = Connection::open_with_flags(db, flags).map_err(sql)?;
    let mut topics = HashMap::new();
    let mut statement = conn
        .prepare("SELECT id, name, type, serialization_format FROM topics ORDER BY id")
        .map_err(sql)?;
    let mut rows = statement.query([]).map_err(sql)?;
    while let Some(row) = rows.next().map_err(sql)? {
        let id: i64 = row.get(0).map_err(sql)?;
        let name: String = row.get(1).map_err(sql)?;
        let type_name: String = row.get(2).map_err(sql)?;
        let encoding: String = row.get(3).map_err(sql)?;
        topics.insert(id, sink.topic(&name, &type_name, &encoding));
    }
    let mut statement = conn
        .prepare("SELECT topic_id, timestamp, data FROM messages ORDER BY timestamp, id")
        .map_err(sql)?;
    let mut rows = statement.query([]).map_err(sql)?;
    while let Some(row) = rows.next().map_err(sql)? {
        let topic_id: i64 = row.get(0).map_err(sql)?;
        let stamp: i64 = row.get(1).map_err(sql)?;
        let data = row.get_ref(2).map_err(sql)?;
        let data = data
            .as_blob()
            .map_err(|e| bad(format!("a message's data is not bytes: {e}")))?;
        let Some(&topic) = topics.get(&topic_id) else {
            return Err(bad(format!(
                "a message refers to topic id {topic_id}, which is not defined"
            )));
        };
        let receive_ns = u64::try_from(stamp)
            .map_err(|_| bad(format!("a message has the negative time {stamp} ns")))?;
        sink.message(topic, receive_ns, data);
    }
    Ok(())
}
