//! The particle cloud (service → viewers): every particle's pose and weight after a
//! filter step, a fixed user header plus a slice of particles. Sent only when the
//! service's `[output] particles_every` asks for it (it is large: one pose per particle).

use crate::header::Header;
use bytemuck::{Pod, Zeroable};
use iceoryx2::prelude::*;

/// Header of a particle cloud; the slice holds one [`Particle`] per particle.
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend, Pod, Zeroable)]
#[type_name("fastslam::ParticlesHeader")]
#[repr(C)]
pub struct ParticlesHeader {
    /// Stamp of the pose estimate the cloud belongs to, and sequence number.
    pub header: Header,
    /// Number of particles in the slice (must equal the slice length).
    pub count: u32,
    /// Reserved, must be 0.
    pub reserved: u32,
}

/// One particle: its pose (frame `map`) and its normalised weight.
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend, Pod, Zeroable)]
#[type_name("fastslam::Particle")]
#[repr(C)]
pub struct Particle {
    /// Position x (m).
    pub x: f64,
    /// Position y (m).
    pub y: f64,
    /// Heading (rad).
    pub theta: f64,
    /// Weight, ≥ 0; the weights of a cloud sum to 1.
    pub weight: f64,
}
