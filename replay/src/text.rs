//! Reading the data sets' text files: plain or gzipped (one member or several), numeric
//! columns separated by commas or white space, `#` comment lines, an optional header
//! line. A missing or unreadable file is an error naming it; a malformed line, a NaN or a
//! time going backwards is skipped and counted, and a file cut short keeps the lines
//! before the cut; [`Table::notice`] says both in one line naming the file and the first
//! lines. Never a panic.

use flate2::read::MultiGzDecoder;
use std::fs::File;
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};

/// What can be wrong with a data set.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum DataError {
    /// Neither `name` nor `name.gz` exists in the folder.
    #[error("{path}: no such file (nor {path}.gz)")]
    Missing {
        /// The file that was looked for.
        path: PathBuf,
    },
    /// The file exists but cannot be read (permissions, broken gzip stream).
    #[error("{path}: {reason}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The operating system's or decoder's message.
        reason: String,
    },
    /// A line does not have the expected columns of finite numbers, or breaks the file's
    /// order.
    #[error("{path}:{line}: {reason}")]
    Malformed {
        /// The file.
        path: PathBuf,
        /// The line number, from 1.
        line: usize,
        /// What is wrong, with the offending text.
        reason: String,
    },
    /// The files parse but do not make a usable data set (no odometry, unknown robot…).
    #[error("{0}")]
    Unusable(String),
    /// One message of a recorded bag does not decode, or holds values no sensor reports.
    #[error("{path}: {topic} message {index}: {reason}")]
    Message {
        /// The storage file holding the message.
        path: PathBuf,
        /// The message's topic.
        topic: String,
        /// The message's position on its topic, from 0, in the bag's storage order.
        index: usize,
        /// What is wrong with it.
        reason: String,
    },
}

/// Result alias of the data-set readers.
pub type Result<T> = std::result::Result<T, DataError>;

/// Records a reader skipped instead of refusing the file: how many, and the first
/// [`Skipped::SHOWN`] errors, for one warning.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Skipped {
    count: usize,
    first: Vec<String>,
}

impl Skipped {
    /// How many errors the warning names.
    pub const SHOWN: usize = 3;

    /// Counts one skipped record, keeping its error among the first few.
    pub fn add(&mut self, error: &DataError) {
        self.count += 1;
        if self.first.len() < Self::SHOWN {
            self.first.push(error.to_string());
        }
    }

    /// How many were skipped.
    pub fn count(&self) -> usize {
        self.count
    }

    /// `"{count} {what} (first error; …)"`, naming the first few; `None` when none was
    /// skipped.
    pub fn phrase(&self, what: &str) -> Option<String> {
        let more = if self.count > self.first.len() {
            "; …"
        } else {
            ""
        };
        (self.count > 0).then(|| format!("{} {what} ({}{more})", self.count, self.first.join("; ")))
    }
}

/// One data line: its line number (from 1) and its columns.
#[derive(Debug, Clone, PartialEq)]
pub struct Row<const N: usize> {
    /// Line number in the file, from 1, for error messages.
    pub line: usize,
    /// The columns, all finite.
    pub values: [f64; N],
}

/// The data rows of one file, with the file's path for error messages.
#[derive(Debug, Clone, PartialEq)]
pub struct Table<const N: usize> {
    /// The file that was read (the `.gz` one if that was used).
    pub path: PathBuf,
    /// Its data rows in file order.
    pub rows: Vec<Row<N>>,
    /// Lines skipped: by [`read`] (malformed, time going back) and by the reader using
    /// the rows (a value no sensor reports), with their errors.
    pub skipped: Skipped,
    /// Where and why the file ended before its end (a gzip stream cut short).
    pub ended_early: Option<String>,
}

impl<const N: usize> Row<N> {
    /// Column `col` (from 0) as a non-negative integer (an id, a count), or why it is not.
    pub fn integer(&self, col: usize) -> std::result::Result<u64, String> {
        let v = self.values[col];
        if v >= 0.0 && v.fract() == 0.0 && v < 2f64.powi(53) {
            Ok(v as u64)
        } else {
            Err(format!(
                "column {} must be a whole number ≥ 0, got {v}",
                col + 1
            ))
        }
    }
}

impl<const N: usize> Table<N> {
    /// Maps every row with `f` and keeps the rows it accepts; a row it refuses, with the
    /// reason, leaves the table and is skipped (counted, its error among the first few).
    pub fn extract<T>(
        &mut self,
        mut f: impl FnMut(&Row<N>) -> std::result::Result<T, String>,
    ) -> Vec<T> {
        let mut kept = Vec::with_capacity(self.rows.len());
        for row in std::mem::take(&mut self.rows) {
            match f(&row) {
                Ok(value) => {
                    kept.push(value);
                    self.rows.push(row);
                }
                Err(reason) => {
                    let error = self.malformed(&row, reason);
                    self.skipped.add(&error);
                }
            }
        }
        kept
    }

    /// What the user should know about this file in one line, naming it: the lines
    /// skipped (with the first errors) and an early end; `None` when nothing was lost.
    pub fn notice(&self) -> Option<String> {
        let parts: Vec<String> = (self.skipped.phrase("lines skipped").into_iter())
            .chain(self.ended_early.clone())
            .collect();
        (!parts.is_empty()).then(|| format!("{}: {}", self.path.display(), parts.join("; ")))
    }

    /// A [`DataError::Malformed`] about `row` of this file.
    pub fn malformed(&self, row: &Row<N>, reason: impl Into<String>) -> DataError {
        DataError::Malformed {
            path: self.path.clone(),
            line: row.line,
            reason: reason.into(),
        }
    }

    /// The first column of the first row (the file's first time), if any.
    pub fn first_time(&self) -> Option<f64> {
        self.rows.first().map(|r| r.values[0])
    }
}

/// How a file is laid out.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Layout {
    /// The first non-comment line names the columns and is skipped.
    pub header_line: bool,
    /// The first column is a time that must not decrease from line to line.
    pub time_ordered: bool,
}

/// A file with a column header line and a time in its first column (the CSV files).
pub const CSV_BY_TIME: Layout = Layout {
    header_line: true,
    time_ordered: true,
};
/// `#` comments only and a time in the first column (MRCLAM's `.dat` logs).
pub const DAT_BY_TIME: Layout = Layout {
    header_line: false,
    time_ordered: true,
};
/// `#` comments only, rows in any order (MRCLAM's tables).
pub const DAT_TABLE: Layout = Layout {
    header_line: false,
    time_ordered: false,
};

/// The path of `name` in `dir`, or of `name.gz` when only the gzipped file exists.
///
/// # Errors
/// [`DataError::Missing`] when neither exists.
pub fn locate(dir: &Path, name: &str) -> Result<PathBuf> {
    let plain = dir.join(name);
    let gz = dir.join(format!("{name}.gz"));
    [plain.clone(), gz]
        .into_iter()
        .find(|p| p.is_file())
        .ok_or(DataError::Missing { path: plain })
}

/// Reads every data row of `name` (or `name.gz`) in `dir`, each with exactly `N` finite
/// numbers. A line with the wrong number of columns, a value that is not a finite number,
/// or (for a time-ordered layout) a time earlier than the row before is skipped and
/// counted; a read error after the first line ends the file there ([`Table::notice`]).
///
/// # Errors
/// [`DataError`] naming the file for a missing file or one that cannot be read at all.
pub fn read<const N: usize>(dir: &Path, name: &str, layout: Layout) -> Result<Table<N>> {
    let path = locate(dir, name)?;
    let io = |e: std::io::Error| DataError::Io {
        path: path.clone(),
        reason: e.to_string(),
    };
    let file = File::open(&path).map_err(io)?;
    let reader: Box<dyn BufRead> = if path.extension().is_some_and(|e| e == "gz") {
        Box::new(BufReader::new(MultiGzDecoder::new(file)))
    } else {
        Box::new(BufReader::new(file))
    };
    let mut table = Table {
        path: path.clone(),
        rows: Vec::new(),
        skipped: Skipped::default(),
        ended_early: None,
    };
    let mut header_pending = layout.header_line;
    let early = each_line(reader, |line, text| {
        let trimmed = text.trim();
        if trimmed.is_empty() || trimmed.starts_with('#') || std::mem::take(&mut header_pending) {
            return;
        }
        let malformed = |reason| DataError::Malformed {
            path: path.clone(),
            line,
            reason,
        };
        let row = match parse_row::<N>(trimmed) {
            Ok(row) => row,
            Err(reason) => return table.skipped.add(&malformed(reason)),
        };
        if let Some(previous) = table.rows.last().filter(|_| layout.time_ordered)
            && row[0] < previous.values[0]
        {
            let reason = format!(
                "time {} goes back before {} (line {})",
                row[0], previous.values[0], previous.line
            );
            return table.skipped.add(&malformed(reason));
        }
        table.rows.push(Row { line, values: row });
    })
    .map_err(io)?;
    table.ended_early = early.map(|end| format!("{end}; the lines before are read"));
    Ok(table)
}

/// The value `read` gives, with each notice of what it skipped (one line per file)
/// logged as a warning.
///
/// # Errors
/// `read`'s error.
pub fn logged<T>(read: Result<(T, Vec<String>)>) -> Result<T> {
    let (value, notices) = read?;
    for notice in notices {
        tracing::warn!("{notice}");
    }
    Ok(value)
}

/// Where a file that could not be read to its end stopped: after which line, and why.
#[derive(Debug)]
pub struct EarlyEnd {
    /// The last line read whole, from 1.
    pub after_line: usize,
    /// The read error that ended it (a gzip stream cut short).
    pub error: std::io::Error,
}

impl std::fmt::Display for EarlyEnd {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let (line, error) = (self.after_line, &self.error);
        write!(f, "the file ends early after line {line} ({error})")
    }
}

/// Calls `f` with every line of `reader` and its number (from 1); bytes that are not
/// UTF-8 are replaced. A read error after the first line ends the reading there and is
/// returned as the [`EarlyEnd`].
///
/// # Errors
/// The read error when not even the first line can be read.
pub fn each_line(
    mut reader: impl BufRead,
    mut f: impl FnMut(usize, &str),
) -> std::io::Result<Option<EarlyEnd>> {
    let (mut buffer, mut line) = (Vec::new(), 0);
    loop {
        buffer.clear();
        match reader.read_until(b'\n', &mut buffer) {
            Ok(0) => return Ok(None),
            Ok(_) => {}
            Err(error) if line > 0 => {
                let after_line = line;
                return Ok(Some(EarlyEnd { after_line, error }));
            }
            Err(error) => return Err(error),
        }
        line += 1;
        f(line, &String::from_utf8_lossy(&buffer));
    }
}

/// The `N` finite numbers of one line, or what is wrong with it.
fn parse_row<const N: usize>(text: &str) -> std::result::Result<[f64; N], String> {
    let fields: Vec<&str> = text
        .split(|c: char| c == ',' || c.is_whitespace())
        .filter(|f| !f.is_empty())
        .collect();
    if fields.len() != N {
        return Err(format!(
            "expected {N} columns, found {}: `{text}`",
            fields.len()
        ));
    }
    let mut values = [0.0; N];
    for (k, (slot, field)) in values.iter_mut().zip(&fields).enumerate() {
        *slot = field
            .parse::<f64>()
            .ok()
            .filter(|v| v.is_finite())
            .ok_or_else(|| format!("column {} is not a finite number: `{field}`", k + 1))?;
    }
    Ok(values)
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use std::io::Write;

    /// A fresh folder holding `files` (name, contents); names ending in `.gz` are gzipped.
    pub(crate) fn folder_with(test: &str, files: &[(&str, &str)]) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("replay-{test}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        for (name, text) in files {
            let file = File::create(dir.join(name)).unwrap();
            if name.ends_with(".gz") {
                let mut gz = flate2::write::GzEncoder::new(file, flate2::Compression::fast());
                gz.write_all(text.as_bytes()).unwrap();
                gz.finish().unwrap();
            } else {
                let mut file = file;
                file.write_all(text.as_bytes()).unwrap();
            }
        }
        dir
    }

    #[test]
    fn reads_plain_and_gzipped_files_alike() {
        let text = "# comment\n1.0 \t 2.0  3\n\n2.5,4,5\n";
        let dir = folder_with("plain-gz", &[("a.dat", text), ("b.dat.gz", text)]);
        let a = read::<3>(&dir, "a.dat", DAT_BY_TIME).unwrap().rows;
        let b = read::<3>(&dir, "b.dat", DAT_BY_TIME).unwrap();
        assert!(b.path.ends_with("b.dat.gz"));
        assert_eq!(a, b.rows);
        assert_eq!(a.len(), 2);
        assert_eq!(a[1].line, 4);
        assert_eq!(a[1].values, [2.5, 4.0, 5.0]);
        std::fs::remove_dir_all(dir).unwrap();
    }

    #[test]
    fn the_header_line_is_skipped_once() {
        let dir = folder_with("header", &[("a.csv", "t_s,v\n0.5,1\n0.75,2\n")]);
        let rows = read::<2>(&dir, "a.csv", CSV_BY_TIME).unwrap().rows;
        assert_eq!(rows.len(), 2);
        assert_eq!(rows[0].line, 2);
        std::fs::remove_dir_all(dir).unwrap();
    }

    #[test]
    fn bad_lines_are_skipped_and_named_with_file_and_line() {
        let cases = [
            (
                "1 2 3\n4 5\n",
                "a.dat: 1 lines skipped (",
                "a.dat:2: expected 3 columns, found 2",
            ),
            (
                "1 2 3\n4 NaN 6\n",
                "",
                "a.dat:2: column 2 is not a finite number: `NaN`",
            ),
            (
                "1 2 3\n2 2 x\n",
                "",
                "a.dat:2: column 3 is not a finite number: `x`",
            ),
            (
                "1 2 3\n2 2 inf\n",
                "",
                "a.dat:2: column 3 is not a finite number",
            ),
            (
                "5 2 3\n4 5 6\n",
                "",
                "a.dat:2: time 4 goes back before 5 (line 1)",
            ),
        ];
        for (text, start, expected) in cases {
            let dir = folder_with("bad", &[("a.dat", text)]);
            let table = read::<3>(&dir, "a.dat", DAT_BY_TIME).unwrap();
            assert_eq!(table.rows.len(), 1, "{text:?}: the good line is kept");
            assert_eq!(table.skipped.count(), 1);
            let notice = table.notice().expect("a skipped line is noticed");
            assert!(
                notice.contains(start) && notice.contains(expected),
                "{notice}"
            );
            std::fs::remove_dir_all(dir).unwrap();
        }
        let dir = folder_with("good", &[("a.dat", "1 2 3\n")]);
        assert_eq!(
            read::<3>(&dir, "a.dat", DAT_BY_TIME).unwrap().notice(),
            None
        );
        std::fs::write(dir.join("b.dat"), b"1 2 3\n\xff 2 3\n2 2 3\n").unwrap();
        let table = read::<3>(&dir, "b.dat", DAT_BY_TIME).unwrap();
        assert_eq!(
            (table.rows.len(), table.skipped.count()),
            (2, 1),
            "not UTF-8"
        );
        std::fs::remove_dir_all(dir).unwrap();
    }

    #[test]
    fn a_gzipped_file_cut_short_keeps_the_lines_before_the_cut() {
        let text: String = (0..2000).map(|i| format!("{i} 1 2\n")).collect();
        let dir = folder_with("cut", &[("a.dat.gz", &text)]);
        let gz = dir.join("a.dat.gz");
        let bytes = std::fs::read(&gz).unwrap();
        std::fs::write(&gz, &bytes[..bytes.len() / 2]).unwrap();
        let table = read::<3>(&dir, "a.dat", DAT_BY_TIME).unwrap();
        assert!(
            !table.rows.is_empty() && table.rows.len() < 2000,
            "{}",
            table.rows.len()
        );
        let notice = table.notice().expect("the early end is noticed");
        assert!(
            notice.contains("a.dat.gz: the file ends early after line"),
            "{notice}"
        );
        std::fs::remove_dir_all(dir).unwrap();
    }

    #[test]
    fn an_unordered_table_may_go_back_but_a_missing_file_is_named() {
        let dir = folder_with("table", &[("t.dat", "5 1\n4 2\n0.5 3\n")]);
        let mut table = read::<2>(&dir, "t.dat", DAT_TABLE).unwrap();
        assert_eq!(table.rows.len(), 3);
        assert_eq!(table.extract(|row| row.integer(0)), [5, 4]);
        assert_eq!(table.rows.len(), 2, "the refused row leaves the table");
        let notice = table.notice().unwrap_or_default();
        assert!(
            notice.contains("t.dat:3: column 1 must be a whole number"),
            "{notice}"
        );
        let err = read::<2>(&dir, "none.dat", DAT_TABLE).unwrap_err();
        assert!(matches!(err, DataError::Missing { .. }), "{err}");
        assert!(err.to_string().contains("none.dat"), "{err}");
        std::fs::remove_dir_all(dir).unwrap();
    }
}
