//! Reads the wire contract out of the protocol README: the type table (name, size,
//! alignment), each type's field table (offset, field, type, unit, meaning) and the
//! services table. The layout test checks these against the Rust types; the bindings
//! test generates the C header and the Python module from them.

#![allow(dead_code)] // each test binary uses a different subset

/// The README, as compiled into the test.
pub const README: &str = include_str!("../../README.md");

/// One documented message type.
#[derive(Debug, Clone, PartialEq)]
pub struct DocType {
    /// Type name, e.g. `fastslam::Odometry`.
    pub name: String,
    /// Size in bytes.
    pub size: usize,
    /// Alignment in bytes.
    pub align: usize,
    /// What it is, one line.
    pub what: String,
    /// Its fields in offset order.
    pub fields: Vec<DocField>,
}

/// One row of a type's field table.
#[derive(Debug, Clone, PartialEq)]
pub struct DocField {
    /// Offset in bytes.
    pub offset: usize,
    /// Field name; `header.seq` for a field of a nested struct.
    pub name: String,
    /// Wire type: `u8`…`u64`, `i8`…`i64`, `f32`, `f64`, or an array `[T; N]` of those or
    /// of a documented type.
    pub ty: String,
    /// Unit.
    pub unit: String,
    /// Meaning.
    pub meaning: String,
}

/// One row of the services table.
#[derive(Debug, Clone, PartialEq)]
pub struct DocTopic {
    /// Service name below the prefix.
    pub name: String,
    /// Payload, as written (`fastslam::Odometry`, `[fastslam::Observation]`, `[f32]` …).
    pub payload: String,
    /// User header type name, empty when there is none.
    pub user_header: String,
    /// Subscriber buffer.
    pub buffer: usize,
    /// History size.
    pub history: usize,
}

/// The cells of a Markdown table row, trimmed, backticks removed.
pub fn cells(line: &str) -> Vec<String> {
    raw_cells(line)
        .iter()
        .map(|c| c.trim_matches('`').to_string())
        .collect()
}

/// The cells of a Markdown table row, trimmed of spaces only (text that may end in code).
pub fn raw_cells(line: &str) -> Vec<String> {
    line.trim()
        .trim_matches('|')
        .split('|')
        .map(|c| c.trim().to_string())
        .collect()
}

/// The README's rows `| type name | size | alignment | what |`.
pub fn documented_sizes(readme: &str) -> Vec<(String, usize, usize)> {
    type_rows(readme)
        .into_iter()
        .map(|c| (c.0, c.1, c.2))
        .collect()
}

fn type_rows(readme: &str) -> Vec<(String, usize, usize, String)> {
    readme
        .lines()
        .map(cells)
        .filter(|c| c.len() == 4 && c[0].starts_with("fastslam::"))
        .filter_map(|c| {
            Some((
                c[0].clone(),
                c[1].parse().ok()?,
                c[2].parse().ok()?,
                c[3].clone(),
            ))
        })
        .collect()
}

/// The offset table under the heading `### \`name\``.
pub fn documented_table(readme: &str, name: &str) -> Vec<DocField> {
    let heading = format!("### `{name}`");
    readme
        .lines()
        .skip_while(|l| l.trim() != heading)
        .skip(1)
        .take_while(|l| !l.starts_with("###"))
        .map(|l| (cells(l), raw_cells(l)))
        .filter(|(c, _)| c.len() >= 5)
        .filter_map(|(c, raw)| {
            Some(DocField {
                offset: c[0].parse().ok()?,
                name: c[1].clone(),
                ty: c[2].clone(),
                unit: c[3].clone(),
                meaning: raw[4..].join("|"),
            })
        })
        .collect()
}

/// (field, offset) pairs of the table under `### \`name\``.
pub fn documented_fields(readme: &str, name: &str) -> Vec<(String, usize)> {
    documented_table(readme, name)
        .into_iter()
        .map(|f| (f.name, f.offset))
        .collect()
}

/// Every documented type with its fields, in README order.
pub fn documented_types(readme: &str) -> Vec<DocType> {
    type_rows(readme)
        .into_iter()
        .map(|(name, size, align, what)| DocType {
            fields: documented_table(readme, &name),
            name,
            size,
            align,
            what,
        })
        .collect()
}

/// The services table: `| topic | payload | user header | buffer | history | sent by |`.
pub fn documented_topics(readme: &str) -> Vec<DocTopic> {
    readme
        .lines()
        .map(cells)
        .filter(|c| c.len() == 6)
        .filter_map(|c| {
            Some(DocTopic {
                buffer: c[3].parse().ok()?,
                history: c[4].parse().ok()?,
                user_header: if c[2] == "—" {
                    String::new()
                } else {
                    c[2].clone()
                },
                payload: c[1].replace('`', ""),
                name: c[0].clone(),
            })
        })
        .collect()
}
