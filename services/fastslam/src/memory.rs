//! The memory a filter will need, estimated before it is built, against the memory the
//! machine has available: a particle count whose filter cannot fit is refused in one line
//! instead of swapping the machine to a halt, and one that takes more than
//! [`WARN_SHARE`] of it is warned about.
//!
//! The estimate is what the particles hold at the start, per particle:
//! - **landmarks** (`[map] kind = "landmarks"`): the particle itself (pose, motion prior,
//!   map and trail handles) twice, as resampling builds the new cloud beside the old, its
//!   weights and its place in the cloud message. Maps grow with the landmarks each
//!   particle adds, so a long run takes more.
//! - **grid** (`[map] kind = "grid"`): the same, and the grid of the first scan, which
//!   every particle integrates into a grid of its own: the copy-on-write tiles of a disc
//!   of radius `[grid] max_range` around the start pose (a scan reaching that far all
//!   round), and the tile index over its bounding square. Resampled copies share tiles
//!   after that, so the grids grow with the area mapped, not with N again.

use crate::config::{MapKind, ServiceConfig};
use fastslam_estimation::fastslam;
use fastslam_estimation::gridslam::{GridParticle, TILE, TILE_BYTES};
use std::mem::size_of;

/// Above this share of the available memory the estimate is warned about.
pub const WARN_SHARE: f64 = 0.5;

/// The memory estimate of the filter `config` sets up (bytes), as the module documentation
/// describes it.
pub fn estimate(config: &ServiceConfig) -> u64 {
    let particles = config.filter.particles as u64;
    let weights = 3 * size_of::<f64>() + size_of::<fastslam_protocol::Particle>();
    let per_particle = match config.map.kind {
        MapKind::Landmarks => 2 * size_of::<fastslam::Particle>() + weights,
        MapKind::Grid => {
            let (tiles, index) = first_scan_tiles(config.grid.resolution, config.grid.max_range);
            2 * size_of::<GridParticle>()
                + weights
                + index * size_of::<usize>()
                + tiles * TILE_BYTES
        }
    };
    particles.saturating_mul(per_particle as u64)
}

/// Tiles of side `TILE · resolution` that a disc of radius `reach` around the origin
/// touches, and the entries of the index over its bounding square.
fn first_scan_tiles(resolution: f64, reach: f64) -> (usize, usize) {
    let side = TILE as f64 * resolution;
    let n = (reach / side).ceil() as i64;
    let mut touched = 0;
    for j in -n..n {
        for i in -n..n {
            // The tile's point nearest the origin.
            let near = |k: i64| {
                let (lo, hi) = (k as f64 * side, (k + 1) as f64 * side);
                0.0_f64.clamp(lo, hi)
            };
            touched += usize::from(near(i).hypot(near(j)) <= reach);
        }
    }
    let span = (2 * n) as usize;
    (touched, span * span)
}

/// Bytes of memory available to a new process (`MemAvailable` of `/proc/meminfo`), or
/// `None` where it cannot be read.
pub fn available() -> Option<u64> {
    let meminfo = std::fs::read_to_string("/proc/meminfo").ok()?;
    mem_available(&meminfo)
}

/// `MemAvailable` of a `/proc/meminfo` text, in bytes.
fn mem_available(meminfo: &str) -> Option<u64> {
    let line = meminfo.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib.saturating_mul(1024))
}

/// `bytes` for people: B, KiB, MiB, GiB, TiB or PiB with one decimal.
pub fn human(bytes: u64) -> String {
    let mut value = bytes as f64;
    for unit in ["B", "KiB", "MiB", "GiB", "TiB"] {
        if value < 1024.0 {
            return format!("{value:.1} {unit}");
        }
        value /= 1024.0;
    }
    format!("{value:.1} PiB")
}

/// Refuses a filter whose [`estimate`] exceeds the `available` memory (bytes; no check
/// when unknown), and warns when it takes more than [`WARN_SHARE`] of it.
///
/// # Errors
/// One line with the particle count, the estimate and what is available.
pub fn check(config: &ServiceConfig, available: Option<u64>) -> anyhow::Result<()> {
    let Some(available) = available else {
        tracing::debug!("available memory unknown: the filter's estimate is not checked");
        return Ok(());
    };
    let needed = estimate(config);
    let particles = config.filter.particles;
    let what = format!(
        "{particles} particles of a {} map need an estimated {} (docs/ESTIMATOR.md, \
         \"Memory\")",
        match config.map.kind {
            MapKind::Landmarks => "landmark",
            MapKind::Grid => "grid",
        },
        human(needed)
    );
    if needed > available {
        anyhow::bail!(
            "{what}, more than the {} this machine has available (MemAvailable): use fewer \
             particles",
            human(available)
        );
    }
    if needed as f64 > WARN_SHARE * available as f64 {
        tracing::warn!(
            "{what}, more than {:.0} % of the {} available (MemAvailable)",
            100.0 * WARN_SHARE,
            human(available)
        );
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn config(kind: MapKind, particles: usize) -> ServiceConfig {
        let mut c = ServiceConfig::default();
        c.map.kind = kind;
        c.filter.particles = particles;
        c
    }

    #[test]
    fn the_estimate_grows_with_the_particles_and_counts_a_grid_scan_per_particle() {
        let landmarks = estimate(&config(MapKind::Landmarks, 1000));
        assert_eq!(estimate(&config(MapKind::Landmarks, 2000)), 2 * landmarks);
        let per_particle = landmarks / 1000;
        assert!(
            (2 * size_of::<fastslam::Particle>() as u64) < per_particle,
            "{per_particle} B"
        );
        let mut grid = config(MapKind::Grid, 1000);
        grid.grid.resolution = 0.05;
        grid.grid.max_range = 16.0;
        // A disc of 16 m in tiles of 1.6 m: π · 10² ≈ 314 tiles, plus those it cuts.
        let (tiles, index) = first_scan_tiles(0.05, 16.0);
        assert!((314..=400).contains(&tiles), "{tiles} tiles");
        assert_eq!(index, 400);
        let grid_per_particle = estimate(&grid) / 1000;
        assert!(grid_per_particle > (tiles * TILE_BYTES) as u64);
        assert!(grid_per_particle < (tiles * TILE_BYTES) as u64 + 10_000);
        let near = estimate(&grid);
        grid.grid.max_range = 32.0;
        assert!(
            estimate(&grid) > 3 * near,
            "twice the reach, four times the tiles"
        );
    }

    #[test]
    fn too_much_is_refused_in_one_line_and_mem_available_is_read_in_kib() {
        let meminfo = "MemTotal:       16000000 kB\nMemAvailable:    8000000 kB\n";
        assert_eq!(mem_available(meminfo), Some(8_192_000_000));
        assert_eq!(mem_available("MemTotal: 1 kB\n"), None);
        let c = config(MapKind::Grid, 1_000_000);
        let err = check(&c, Some(8_192_000_000)).unwrap_err().to_string();
        assert!(!err.contains('\n'), "{err}");
        assert!(
            err.contains("1000000 particles")
                && err.contains("the 7.6 GiB this machine has available"),
            "{err}"
        );
        check(&c, None).unwrap();
        check(&config(MapKind::Landmarks, 100), Some(8_192_000_000)).unwrap();
        assert_eq!(human(1536), "1.5 KiB");
        assert_eq!(human(3 << 40), "3.0 TiB");
    }
}
