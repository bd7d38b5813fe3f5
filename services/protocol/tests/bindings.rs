//! The protocol for other languages: a C header (`include/fastslam_protocol.h`) and a
//! Python ctypes module (`python/fastslam_protocol.py`), both generated from the README's
//! tables — which the layout test keeps equal to the Rust types — plus the topic settings
//! of `topics::TABLE`. This test regenerates both and fails when the checked-in files differ.
//!
//! After changing a message type, its README table or a topic, regenerate them with
//!
//! ```sh
//! FASTSLAM_BLESS=1 cargo test --release -p fastslam-protocol --test bindings
//! ```
//!
//! Adding a type: its README table (and its `layout!` line in `tests/layout.rs`), then
//! bless. Adding a topic: its README row and its row in [`topics::TABLE`], then bless.

mod readme;

use fastslam_protocol::StreamId;
use fastslam_protocol::topics::{self, Topic};
use readme::{DocField, DocTopic, DocType, README, documented_topics, documented_types};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Every topic of [`topics::TABLE`]; the README's services table must list exactly these.
fn rust_topics() -> Vec<Topic> {
    topics::TABLE.iter().map(|row| row.topic).collect()
}

/// A wire type: its element (`f64`, …) and how many (1, or N for `[T; N]`).
fn element(ty: &str) -> (&str, usize) {
    match ty.strip_prefix('[').and_then(|t| t.strip_suffix(']')) {
        Some(inner) => {
            let (t, n) = inner.split_once(';').expect("array type `[T; N]`");
            (t.trim(), n.trim().parse().expect("array length"))
        }
        None => (ty, 1),
    }
}

/// (C type, ctypes type, size) of a wire type: a scalar, or a type of `types` (an array
/// element such as `StreamStatus`).
fn wire(types: &[DocType], ty: &str) -> (String, String, usize) {
    match types.iter().find(|t| short(&t.name) == ty) {
        Some(t) => (format!("fastslam_{ty}"), ty.to_string(), t.size),
        None => {
            let (c, py, size) = scalar(ty);
            (c.to_string(), py.to_string(), size)
        }
    }
}

/// (C type, ctypes type, size) of a scalar wire type.
fn scalar(ty: &str) -> (&'static str, &'static str, usize) {
    match ty {
        "u8" => ("uint8_t", "ctypes.c_uint8", 1),
        "i8" => ("int8_t", "ctypes.c_int8", 1),
        "u16" => ("uint16_t", "ctypes.c_uint16", 2),
        "i16" => ("int16_t", "ctypes.c_int16", 2),
        "u32" => ("uint32_t", "ctypes.c_uint32", 4),
        "i32" => ("int32_t", "ctypes.c_int32", 4),
        "u64" => ("uint64_t", "ctypes.c_uint64", 8),
        "i64" => ("int64_t", "ctypes.c_int64", 8),
        "f32" => ("float", "ctypes.c_float", 4),
        "f64" => ("double", "ctypes.c_double", 8),
        other => panic!("wire type `{other}` has no C/Python mapping: add it to `scalar`"),
    }
}

/// A member of a generated struct: a scalar/array field, or a nested struct (`header`)
/// grouping the README's dotted fields.
enum Member<'a> {
    Field(&'a DocField),
    Nested {
        name: &'a str,
        fields: Vec<&'a DocField>,
    },
}

fn members(t: &DocType) -> Vec<Member<'_>> {
    let mut out: Vec<Member> = Vec::new();
    for f in &t.fields {
        match f.name.split_once('.') {
            Some((outer, _)) => match out.last_mut() {
                Some(Member::Nested { name, fields }) if *name == outer => fields.push(f),
                _ => out.push(Member::Nested {
                    name: outer,
                    fields: vec![f],
                }),
            },
            None => out.push(Member::Field(f)),
        }
    }
    out
}

/// A field of a nested struct: (name, scalar type, unit).
type Leaf<'a> = (&'a str, &'a str, &'a str);

/// The nested structs (`Header`) of all types, each once: type name and its fields.
fn nested_structs(types: &[DocType]) -> Vec<(String, Vec<Leaf<'_>>)> {
    let mut out: Vec<(String, Vec<Leaf>)> = Vec::new();
    for m in types.iter().flat_map(members) {
        if let Member::Nested { name, fields } = m {
            let ty = nested_type(name);
            if !out.iter().any(|(t, _)| *t == ty) {
                let leaves = (fields.iter())
                    .map(|f| {
                        (
                            f.name.split_once('.').unwrap().1,
                            element(&f.ty).0,
                            f.unit.as_str(),
                        )
                    })
                    .collect();
                out.push((ty, leaves));
            }
        }
    }
    out
}

/// `header` → `Header`: the nested struct's type name.
fn nested_type(name: &str) -> String {
    let mut c = name.chars();
    c.next()
        .map(|f| f.to_ascii_uppercase())
        .into_iter()
        .chain(c)
        .collect()
}

/// `fastslam::MapLandmark` → `MapLandmark`.
fn short(type_name: &str) -> &str {
    type_name.trim_start_matches("fastslam::")
}

/// `truth/landmarks` → `TRUTH_LANDMARKS`; `GroundTruth` → `GROUND_TRUTH`.
fn constant(name: &str) -> String {
    let mut out = String::new();
    for (i, c) in name.chars().enumerate() {
        if c.is_ascii_uppercase() && i > 0 {
            out.push('_');
        }
        out.push(if c.is_ascii_alphanumeric() {
            c.to_ascii_uppercase()
        } else {
            '_'
        });
    }
    out
}

/// The stream ids of [`StreamId`], for end-of-stream messages.
fn streams() -> Vec<(String, u32)> {
    (StreamId::ALL.into_iter())
        .map(|s| (constant(&format!("{s:?}")), s as u32))
        .collect()
}

/// Checks that the fields tile the type: each field's width is the gap to the next
/// offset (or to the end), so the documented types are consistent with the offsets.
fn check_widths(types: &[DocType], t: &DocType) {
    for (k, f) in t.fields.iter().enumerate() {
        let (e, n) = element(&f.ty);
        let end = t.fields.get(k + 1).map_or(t.size, |g| g.offset);
        assert_eq!(
            f.offset + wire(types, e).2 * n,
            end,
            "{}: field `{}` ({}) at {} does not end where the next begins",
            t.name,
            f.name,
            f.ty,
            f.offset
        );
    }
}

fn c_header(types: &[DocType], topics: &[DocTopic]) -> String {
    let mut h = String::new();
    let w = &mut h;
    writeln!(
        w,
        "/* The FastSLAM stack's wire contract for C and C++ (C11)."
    )
    .unwrap();
    writeln!(
        w,
        " * GENERATED from services/protocol/README.md by tests/bindings.rs: do not edit;"
    )
    .unwrap();
    writeln!(
        w,
        " * regenerate with FASTSLAM_BLESS=1 cargo test -p fastslam-protocol --test bindings."
    )
    .unwrap();
    writeln!(
        w,
        " * Publish with iceoryx2's C/C++ bindings: the type name, size and alignment of the"
    )
    .unwrap();
    writeln!(
        w,
        " * payload must be the ones below; every topic is a publish-subscribe and an event"
    )
    .unwrap();
    writeln!(
        w,
        " * service named <prefix>/<topic>, safe overflow off, the buffer and history below. */"
    )
    .unwrap();
    writeln!(
        w,
        "#ifndef FASTSLAM_PROTOCOL_H\n#define FASTSLAM_PROTOCOL_H\n"
    )
    .unwrap();
    writeln!(w, "#include <stddef.h>\n#include <stdint.h>\n").unwrap();
    writeln!(
        w,
        "#define FASTSLAM_MAX_PUBLISHERS {}",
        topics::MAX_PUBLISHERS
    )
    .unwrap();
    writeln!(
        w,
        "#define FASTSLAM_MAX_SUBSCRIBERS {}\n",
        topics::MAX_SUBSCRIBERS
    )
    .unwrap();
    for t in topics {
        let c = constant(&t.name);
        writeln!(
            w,
            "/* {}: payload {}, user header {} */",
            t.name,
            t.payload,
            none_dash(&t.user_header)
        )
        .unwrap();
        writeln!(w, "#define FASTSLAM_TOPIC_{c} \"{}\"", t.name).unwrap();
        writeln!(w, "#define FASTSLAM_TOPIC_{c}_BUFFER {}", t.buffer).unwrap();
        writeln!(w, "#define FASTSLAM_TOPIC_{c}_HISTORY {}\n", t.history).unwrap();
    }
    for (name, k) in streams() {
        writeln!(w, "#define FASTSLAM_STREAM_{name} {k}").unwrap();
    }
    for (ty, fields) in nested_structs(types) {
        writeln!(w, "\ntypedef struct fastslam_{ty} {{").unwrap();
        for (leaf, scalar_ty, unit) in fields {
            writeln!(w, "    {} {leaf}; /* {unit} */", scalar(scalar_ty).0).unwrap();
        }
        writeln!(w, "}} fastslam_{ty};").unwrap();
    }
    for t in types {
        let s = short(&t.name);
        writeln!(w, "\n/* {}: {} */", t.name, t.what).unwrap();
        writeln!(
            w,
            "#define FASTSLAM_{}_TYPE_NAME \"{}\"",
            constant(s),
            t.name
        )
        .unwrap();
        writeln!(w, "typedef struct fastslam_{s} {{").unwrap();
        for m in members(t) {
            match m {
                Member::Field(f) => c_field(w, types, &f.name, f),
                Member::Nested { name, .. } => {
                    writeln!(w, "    fastslam_{} {name};", nested_type(name)).unwrap()
                }
            }
        }
        writeln!(w, "}} fastslam_{s};").unwrap();
        let msg = format!("\"fastslam_{s} must match the Rust layout\"");
        writeln!(
            w,
            "_Static_assert(sizeof(fastslam_{s}) == {}, {msg});",
            t.size
        )
        .unwrap();
        writeln!(
            w,
            "_Static_assert(_Alignof(fastslam_{s}) == {}, {msg});",
            t.align
        )
        .unwrap();
        for f in &t.fields {
            writeln!(
                w,
                "_Static_assert(offsetof(fastslam_{s}, {}) == {}, {msg});",
                f.name, f.offset
            )
            .unwrap();
        }
    }
    writeln!(w, "\n#endif /* FASTSLAM_PROTOCOL_H */").unwrap();
    h
}

fn none_dash(s: &str) -> &str {
    if s.is_empty() { "none" } else { s }
}

fn c_field(w: &mut String, types: &[DocType], name: &str, f: &DocField) {
    let (e, n) = element(&f.ty);
    let array = if n > 1 {
        format!("[{n}]")
    } else {
        String::new()
    };
    writeln!(
        w,
        "    {} {name}{array}; /* {}: {} */",
        wire(types, e).0,
        f.unit,
        f.meaning
    )
    .unwrap();
}

fn python_module(types: &[DocType], topics: &[DocTopic]) -> String {
    let mut p = String::new();
    let w = &mut p;
    writeln!(
        w,
        "\"\"\"The FastSLAM stack's wire contract for Python: ctypes structures with the"
    )
    .unwrap();
    writeln!(
        w,
        "protocol's type names, sizes and alignments, and the topics' settings."
    )
    .unwrap();
    writeln!(
        w,
        "\nGENERATED from services/protocol/README.md by tests/bindings.rs: do not edit;"
    )
    .unwrap();
    writeln!(
        w,
        "regenerate with FASTSLAM_BLESS=1 cargo test -p fastslam-protocol --test bindings."
    )
    .unwrap();
    writeln!(
        w,
        "Use with the iceoryx2 wheel (0.10): the structures carry `type_name()`."
    )
    .unwrap();
    writeln!(
        w,
        "\nA received slice sample's `len()` is its payload's size in bytes, not in elements:"
    )
    .unwrap();
    writeln!(
        w,
        "take the element count from the user header (a map's `LandmarkMapHeader.count`,"
    )
    .unwrap();
    writeln!(
        w,
        "an observation message's `ObservationsHeader.count`).\n\"\"\"\n"
    )
    .unwrap();
    writeln!(w, "import ctypes\nfrom typing import NamedTuple\n").unwrap();
    writeln!(w, "MAX_PUBLISHERS = {}", topics::MAX_PUBLISHERS).unwrap();
    writeln!(w, "MAX_SUBSCRIBERS = {}\n", topics::MAX_SUBSCRIBERS).unwrap();
    writeln!(w, "\nclass Topic(NamedTuple):").unwrap();
    writeln!(w, "    \"\"\"A topic: service name below the prefix, subscriber buffer, history, payload.\"\"\"\n").unwrap();
    writeln!(
        w,
        "    name: str\n    buffer: int\n    history: int\n    payload: str\n    user_header: str\n"
    )
    .unwrap();
    for t in topics {
        writeln!(
            w,
            "\n{} = Topic({:?}, {}, {}, {:?}, {:?})",
            constant(&t.name),
            t.name,
            t.buffer,
            t.history,
            t.payload,
            t.user_header
        )
        .unwrap();
    }
    writeln!(w).unwrap();
    for (name, k) in streams() {
        writeln!(w, "STREAM_{name} = {k}").unwrap();
    }
    for (ty, fields) in nested_structs(types) {
        writeln!(w, "\n\nclass {ty}(ctypes.Structure):").unwrap();
        writeln!(
            w,
            "    \"\"\"The `{}` of a message.\"\"\"\n",
            ty.to_lowercase()
        )
        .unwrap();
        writeln!(w, "    _fields_ = [").unwrap();
        for (leaf, scalar_ty, unit) in fields {
            writeln!(w, "        ({leaf:?}, {}),  # {unit}", scalar(scalar_ty).1).unwrap();
        }
        writeln!(w, "    ]").unwrap();
    }
    for t in types {
        let s = short(&t.name);
        writeln!(w, "\n\nclass {s}(ctypes.Structure):").unwrap();
        writeln!(
            w,
            "    \"\"\"`{}` ({} bytes, alignment {}): {}.\"\"\"\n",
            t.name, t.size, t.align, t.what
        )
        .unwrap();
        writeln!(w, "    _fields_ = [").unwrap();
        for m in members(t) {
            match m {
                Member::Field(f) => py_field(w, types, &f.name, f),
                Member::Nested { name, .. } => {
                    writeln!(w, "        ({name:?}, {}),", nested_type(name)).unwrap()
                }
            }
        }
        writeln!(w, "    ]\n").unwrap();
        writeln!(w, "    @staticmethod\n    def type_name() -> str:").unwrap();
        writeln!(
            w,
            "        \"\"\"The iceoryx2 type name, as the Rust side declares it.\"\"\"\n"
        )
        .unwrap();
        writeln!(w, "        return {:?}", t.name).unwrap();
    }
    writeln!(
        w,
        "\n\n# The layouts above must equal the Rust ones (checked on import)."
    )
    .unwrap();
    writeln!(w, "LAYOUTS = {{").unwrap();
    for t in types {
        let offsets: Vec<String> = members(t)
            .iter()
            .map(|m| match m {
                Member::Field(f) => format!("{:?}: {}", f.name, f.offset),
                Member::Nested { name, fields } => format!("{name:?}: {}", fields[0].offset),
            })
            .collect();
        writeln!(
            w,
            "    {}: ({}, {}, {{{}}}),",
            short(&t.name),
            t.size,
            t.align,
            offsets.join(", ")
        )
        .unwrap();
    }
    writeln!(w, "}}").unwrap();
    writeln!(w, "for _t, (_size, _align, _offsets) in LAYOUTS.items():").unwrap();
    writeln!(w, "    assert ctypes.sizeof(_t) == _size, _t").unwrap();
    writeln!(w, "    assert ctypes.alignment(_t) == _align, _t").unwrap();
    writeln!(w, "    for _field, _offset in _offsets.items():").unwrap();
    writeln!(
        w,
        "        assert getattr(_t, _field).offset == _offset, (_t, _field)"
    )
    .unwrap();
    p
}

fn py_field(w: &mut String, types: &[DocType], name: &str, f: &DocField) {
    let (e, n) = element(&f.ty);
    let ty = if n > 1 {
        format!("{} * {n}", wire(types, e).1)
    } else {
        wire(types, e).1
    };
    writeln!(w, "        ({name:?}, {ty}),  # {}: {}", f.unit, f.meaning).unwrap();
}

/// Compares `generated` with the checked-in file (or writes it when blessing).
fn check_file(relative: &str, generated: &str) -> PathBuf {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(relative);
    if std::env::var_os("FASTSLAM_BLESS").is_some() {
        std::fs::write(&path, generated).unwrap();
    }
    let current = std::fs::read_to_string(&path).unwrap_or_default();
    assert!(
        current == generated,
        "{} is out of date with the README: regenerate it with\n  FASTSLAM_BLESS=1 cargo test --release -p fastslam-protocol --test bindings",
        path.display()
    );
    path
}

#[test]
fn the_readme_types_tile_their_sizes_and_topics_match_topics_rs() {
    let types = documented_types(README);
    assert!(types.len() >= 9, "{types:?}");
    for t in &types {
        assert!(!t.fields.is_empty(), "{} has no field table", t.name);
        check_widths(&types, t);
    }
    let documented = documented_topics(README);
    let rust = rust_topics();
    assert_eq!(
        documented.len(),
        rust.len(),
        "every topic in README and rust_topics(): {documented:?}"
    );
    for topic in rust {
        let doc = documented
            .iter()
            .find(|d| d.name == topic.name)
            .unwrap_or_else(|| panic!("topic {} not in the README", topic.name));
        assert_eq!(
            (doc.buffer, doc.history),
            (topic.buffer, topic.history),
            "{}",
            topic.name
        );
    }
}

#[test]
fn the_c_header_and_python_module_are_generated_from_the_contract() {
    let (types, topics) = (documented_types(README), documented_topics(README));
    let header = check_file("include/fastslam_protocol.h", &c_header(&types, &topics));
    check_file(
        "python/fastslam_protocol.py",
        &python_module(&types, &topics),
    );
    // The header's static assertions check the layout with a real C compiler.
    let cc = std::env::var("CC").unwrap_or_else(|_| "cc".into());
    let out = std::process::Command::new(&cc)
        .args(["-std=c11", "-fsyntax-only", "-Wall", "-Werror", "-x", "c"])
        .arg(&header)
        .output()
        .unwrap_or_else(|e| panic!("running the C compiler `{cc}` (set CC): {e}"));
    assert!(
        out.status.success(),
        "{} does not compile:\n{}",
        header.display(),
        String::from_utf8_lossy(&out.stderr)
    );
}
