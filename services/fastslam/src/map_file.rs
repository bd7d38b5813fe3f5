//! Saved landmark maps: the file `--save-map` writes and `--load-map` reads.
//!
//! # File format
//! CSV, one landmark per line after a header row, the same columns as the run folder's
//! `map.csv` (so a map saved by the client loads too):
//! ```text
//! id,x,y,cov_xx,cov_xy,cov_yy,observations
//! 0,12.5,-3.25,0.0004,0.00001,0.0003,41
//! ```
//! `id` is the landmark's id (unsigned), `x, y` its mean in the map frame (m; the map
//! frame is the pose the mapping run started at), `cov_*` its 2×2 covariance (m²),
//! `observations` how many scans saw it. Numbers are written with Rust's shortest exact
//! representation, so a map survives a save–load round trip bit for bit. Lines starting
//! with `#` are comments. Files are written atomically (temporary file + rename).

use crate::checkpoint::write_atomically;
use fastslam_protocol::MapLandmark;
use fastslam_protocol::landmarks::{MAP_CSV_HEADER, map_csv};
use std::path::{Path, PathBuf};

/// Why a map file could not be written or read.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum MapFileError {
    /// The file could not be read or written.
    #[error("map {path}: {error}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The operating system's reason (in the message, not a separate cause, so the
        /// error reads as one line).
        error: std::io::Error,
    },
    /// A line is not a landmark of this format.
    #[error("map {path}, line {line}: {reason}")]
    Parse {
        /// The file.
        path: PathBuf,
        /// Line number (1-based).
        line: usize,
        /// What is wrong with it.
        reason: String,
    },
}

/// Parses file contents; `path` only names the file in errors.
///
/// # Errors
/// [`MapFileError::Parse`] for a missing header, a line without seven fields, or a field
/// that is not a number (finiteness and positive definiteness are the filter's checks).
pub fn from_csv(text: &str, path: &Path) -> Result<Vec<MapLandmark>, MapFileError> {
    let error = |line: usize, reason: String| MapFileError::Parse {
        path: path.to_path_buf(),
        line,
        reason,
    };
    let mut lines = text
        .lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.trim()))
        .filter(|(_, l)| !l.is_empty() && !l.starts_with('#'));
    match lines.next() {
        Some((_, MAP_CSV_HEADER)) => {}
        Some((n, _)) => return Err(error(n, format!("expected the header `{MAP_CSV_HEADER}`"))),
        None => {
            return Err(error(
                1,
                format!("empty, expected the header `{MAP_CSV_HEADER}`"),
            ));
        }
    }
    lines
        .map(|(n, line)| {
            let fields: Vec<&str> = line.split(',').map(str::trim).collect();
            if fields.len() != 7 {
                return Err(error(n, format!("{} fields, expected 7", fields.len())));
            }
            let float = |k: usize| {
                fields[k]
                    .parse::<f64>()
                    .map_err(|e| error(n, format!("field {k} `{}`: {e}", fields[k])))
            };
            let int = |k: usize| {
                fields[k]
                    .parse::<u64>()
                    .map_err(|e| error(n, format!("field {k} `{}`: {e}", fields[k])))
            };
            Ok(MapLandmark {
                id: int(0)?,
                x: float(1)?,
                y: float(2)?,
                cov_xx: float(3)?,
                cov_xy: float(4)?,
                cov_yy: float(5)?,
                observations: int(6)?,
            })
        })
        .collect()
}

/// Writes `map` to `path` atomically.
///
/// # Errors
/// [`MapFileError::Io`] when the file cannot be written.
pub fn save(path: &Path, map: &[MapLandmark]) -> Result<(), MapFileError> {
    write_atomically(path, map_csv(map).as_bytes()).map_err(|error| MapFileError::Io {
        path: path.to_path_buf(),
        error,
    })
}

/// Reads the map at `path`.
///
/// # Errors
/// [`MapFileError::Io`] when it cannot be read, [`MapFileError::Parse`] as [`from_csv`].
pub fn load(path: &Path) -> Result<Vec<MapLandmark>, MapFileError> {
    let text = std::fs::read_to_string(path).map_err(|error| MapFileError::Io {
        path: path.to_path_buf(),
        error,
    })?;
    from_csv(&text, path)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_map_survives_the_csv_round_trip_exactly() {
        let map = vec![
            MapLandmark {
                id: 3,
                x: 0.1 + 0.2,
                y: -1.0 / 3.0,
                cov_xx: 1e-5,
                cov_xy: -2.5e-7,
                cov_yy: 3e-5,
                observations: 12,
            },
            MapLandmark {
                id: 9,
                x: 1e6,
                ..MapLandmark::default()
            },
        ];
        let text = format!("# saved by a test\n{}", map_csv(&map));
        assert_eq!(from_csv(&text, Path::new("m.csv")).unwrap(), map);
    }

    #[test]
    fn bad_lines_are_refused_with_their_line_number() {
        let path = Path::new("m.csv");
        let err = from_csv("x,y\n", path).unwrap_err();
        assert!(err.to_string().contains("line 1"), "{err}");
        let text = format!("{MAP_CSV_HEADER}\n1,2,3,4,5,6,7\n2,2,3,abc,5,6,7\n");
        let err = from_csv(&text, path).unwrap_err();
        assert!(
            err.to_string()
                .starts_with("map m.csv, line 3: field 3 `abc`"),
            "{err}"
        );
        let err = from_csv(&format!("{MAP_CSV_HEADER}\n1,2,3\n"), path).unwrap_err();
        assert!(err.to_string().contains("3 fields"), "{err}");
    }
}
