//! The bytes one message takes between hosts: a small header that says what follows
//! (the contract version, the type names and their sizes), then the message's own
//! `#[repr(C)]` bytes as they lie in shared memory. A frame whose header does not match
//! what this side expects on the topic is refused with the reason ([`Refused`]).
//!
//! Layout, little-endian: `"FSZB"`, contract version (u32), size of the fixed part
//! (u32), size of one slice element (u32, 0 for a fixed-size message), length of the
//! type name (u16), the type name (UTF-8), then the fixed part and the elements.

use fastslam_protocol::CONTRACT_VERSION;

/// The first four bytes of every frame.
pub const MAGIC: [u8; 4] = *b"FSZB";

/// Bytes before the type name.
const HEAD: usize = 4 + 4 + 4 + 4 + 2;

/// What a topic carries: the message's type name (for a slice topic, header and element,
/// `fastslam::LandmarkMapHeader + [fastslam::MapLandmark]`) and sizes.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Kind {
    /// The contract's type name(s).
    pub name: String,
    /// Size of the fixed-size message, or of a slice message's header (bytes).
    pub fixed_size: u32,
    /// Size of one slice element (bytes); 0 for a fixed-size message.
    pub element_size: u32,
}

/// Why a frame is refused.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum Refused {
    /// It does not start like a frame.
    #[error("not a bridge frame: it starts with {0:02x?}, not \"FSZB\"")]
    NotAFrame(Vec<u8>),
    /// Another contract version.
    #[error(
        "the peer speaks contract version {peer} and this bridge {ours}: run the same release of the stack on both hosts"
    )]
    Contract {
        /// The peer's version.
        peer: u32,
        /// This side's.
        ours: u32,
    },
    /// Another type on the same topic.
    #[error("the peer sends {peer} and this bridge expects {ours}")]
    Type {
        /// What the peer says it sends.
        peer: String,
        /// What this side expects.
        ours: String,
    },
    /// Shorter than its header says, or a body that is not whole messages.
    #[error("malformed frame: {0}")]
    Malformed(String),
}

impl Kind {
    /// Shows the type with its sizes, for errors.
    fn show(&self) -> String {
        match self.element_size {
            0 => format!("`{}` ({} bytes)", self.name, self.fixed_size),
            e => format!("`{}` ({} + n × {e} bytes)", self.name, self.fixed_size),
        }
    }
}

/// Writes the frame of the message whose bytes are `body` (fixed part, then elements) into
/// `out` (cleared first).
pub fn encode(kind: &Kind, body: &[u8], out: &mut Vec<u8>) {
    out.clear();
    let name = kind.name.as_bytes();
    out.extend_from_slice(&MAGIC);
    out.extend_from_slice(&CONTRACT_VERSION.to_le_bytes());
    out.extend_from_slice(&kind.fixed_size.to_le_bytes());
    out.extend_from_slice(&kind.element_size.to_le_bytes());
    let len = u16::try_from(name.len()).expect("type names are short");
    out.extend_from_slice(&len.to_le_bytes());
    out.extend_from_slice(name);
    out.extend_from_slice(body);
}

/// The message bytes of `frame`, if its header announces `expected` under this side's
/// contract version and the body holds whole messages.
///
/// # Errors
/// [`Refused`] with the reason.
pub fn decode<'a>(expected: &Kind, frame: &'a [u8]) -> Result<&'a [u8], Refused> {
    if frame.len() < 4 || frame[..4] != MAGIC {
        return Err(Refused::NotAFrame(frame[..frame.len().min(4)].to_vec()));
    }
    if frame.len() < HEAD {
        return Err(Refused::Malformed(format!(
            "{} bytes, shorter than a frame header",
            frame.len()
        )));
    }
    let u32_at = |at: usize| u32::from_le_bytes(frame[at..at + 4].try_into().expect("4 bytes"));
    let contract = u32_at(4);
    if contract != CONTRACT_VERSION {
        return Err(Refused::Contract {
            peer: contract,
            ours: CONTRACT_VERSION,
        });
    }
    let name_len = usize::from(u16::from_le_bytes([frame[16], frame[17]]));
    let Some(name) = frame.get(HEAD..HEAD + name_len) else {
        return Err(Refused::Malformed(format!(
            "a type name of {name_len} bytes in a frame of {}",
            frame.len()
        )));
    };
    let peer = Kind {
        name: String::from_utf8_lossy(name).into_owned(),
        fixed_size: u32_at(8),
        element_size: u32_at(12),
    };
    if peer != *expected {
        return Err(Refused::Type {
            peer: peer.show(),
            ours: expected.show(),
        });
    }
    let body = &frame[HEAD + name_len..];
    let fixed = expected.fixed_size as usize;
    let whole = match expected.element_size {
        0 => body.len() == fixed,
        e => body.len() >= fixed && (body.len() - fixed).is_multiple_of(e as usize),
    };
    if !whole {
        return Err(Refused::Malformed(format!(
            "a body of {} bytes is not one {}",
            body.len(),
            expected.show()
        )));
    }
    Ok(body)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn odometry() -> Kind {
        Kind {
            name: "fastslam::Odometry".into(),
            fixed_size: 64,
            element_size: 0,
        }
    }

    fn map() -> Kind {
        Kind {
            name: "fastslam::LandmarkMapHeader + [fastslam::MapLandmark]".into(),
            fixed_size: 24,
            element_size: 56,
        }
    }

    #[test]
    fn a_frame_gives_back_the_bytes_it_was_made_of() {
        let mut frame = Vec::new();
        let body: Vec<u8> = (0..64).collect();
        encode(&odometry(), &body, &mut frame);
        assert_eq!(decode(&odometry(), &frame), Ok(&body[..]));
        let header = [7u8; 24];
        let elements = [9u8; 112];
        encode(&map(), &[&header[..], &elements[..]].concat(), &mut frame);
        let got = decode(&map(), &frame).unwrap();
        assert_eq!(&got[..24], &header);
        assert_eq!(&got[24..], &elements);
    }

    #[test]
    fn another_contract_version_is_refused_with_both_versions() {
        let mut frame = Vec::new();
        encode(&odometry(), &[0; 64], &mut frame);
        frame[4..8].copy_from_slice(&(CONTRACT_VERSION + 1).to_le_bytes());
        let refused = decode(&odometry(), &frame).unwrap_err();
        assert_eq!(
            refused,
            Refused::Contract {
                peer: CONTRACT_VERSION + 1,
                ours: CONTRACT_VERSION
            }
        );
        assert!(refused.to_string().contains("same release"), "{refused}");
    }

    #[test]
    fn another_type_or_size_is_refused_naming_both() {
        let mut frame = Vec::new();
        encode(&map(), &[0; 24], &mut frame);
        let refused = decode(&odometry(), &frame).unwrap_err().to_string();
        assert!(
            refused.contains("fastslam::MapLandmark") && refused.contains("fastslam::Odometry")
        );
        let mut bigger = odometry();
        bigger.fixed_size = 72;
        encode(&bigger, &[0; 72], &mut frame);
        let refused = decode(&odometry(), &frame).unwrap_err().to_string();
        assert!(
            refused.contains("72 bytes") && refused.contains("64 bytes"),
            "{refused}"
        );
    }

    #[test]
    fn garbage_and_cut_frames_are_refused_not_read() {
        assert!(matches!(
            decode(&odometry(), b"hello"),
            Err(Refused::NotAFrame(_))
        ));
        assert!(matches!(
            decode(&odometry(), b""),
            Err(Refused::NotAFrame(_))
        ));
        let mut frame = Vec::new();
        encode(&odometry(), &[0; 64], &mut frame);
        for cut in [6, HEAD + 3, frame.len() - 1] {
            assert!(
                matches!(
                    decode(&odometry(), &frame[..cut]),
                    Err(Refused::Malformed(_))
                ),
                "cut at {cut}"
            );
        }
        encode(&map(), &[0; 24 + 55], &mut frame);
        assert!(matches!(decode(&map(), &frame), Err(Refused::Malformed(_))));
    }
}
