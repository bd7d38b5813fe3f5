//! The occupancy grid in the run folder: `map.pgm` + `map.yaml` in the format of ROS's
//! map_server (so `nav2_map_server` and friends load it as is), and `map.png` to look at.

use fastslam_protocol::OccupancyGridHeader;
use std::fs;
use std::io::{BufWriter, Write};
use std::path::Path;

/// The map image, map_server's PGM (`P5`): 254 free, 0 occupied, 205 unknown, image row 0
/// is the top (largest y) of the map.
pub const MAP_PGM: &str = "map.pgm";
/// map_server's YAML beside the PGM: image, resolution, origin, thresholds.
pub const MAP_YAML: &str = "map.yaml";
/// The grid as a greyscale PNG: white free … black occupied, by probability; unknown
/// cells are map_server's grey (205).
pub const MAP_PNG: &str = "map.png";

/// map_server's `occupied_thresh`: cells at least this likely occupied are black.
pub const OCCUPIED_THRESH: f64 = 0.65;
/// map_server's `free_thresh`: cells at most this likely occupied are white.
pub const FREE_THRESH: f64 = 0.25;

/// PGM value of an unknown cell.
const UNKNOWN: u8 = 205;

/// map_server's trinary value of a cell (−1 unknown, else occupancy in percent).
pub fn trinary(cell: i8) -> u8 {
    let p = f64::from(cell) / 100.0;
    match cell {
        c if c < 0 => UNKNOWN,
        _ if p >= OCCUPIED_THRESH => 0,
        _ if p <= FREE_THRESH => 254,
        _ => UNKNOWN,
    }
}

/// A shade of grey by occupancy: 255 certainly free … 0 certainly occupied.
fn shade(cell: i8) -> u8 {
    if cell < 0 {
        UNKNOWN
    } else {
        255 - (2.55 * f64::from(cell.min(100))).round() as u8
    }
}

/// The cells as image rows, top row first (the grid's row 0 is the bottom of the map).
fn rows<'a>(h: &OccupancyGridHeader, cells: &'a [i8]) -> impl Iterator<Item = &'a [i8]> {
    let width = (h.width as usize).max(1);
    cells.chunks(width).rev()
}

/// Writes `map.pgm`, `map.yaml` and `map.png` into `dir` (the grid is validated by the
/// receiver: `cells.len() == width · height`).
///
/// # Errors
/// When a file cannot be written or the PNG cannot be encoded.
pub fn write(dir: &Path, h: &OccupancyGridHeader, cells: &[i8]) -> std::io::Result<()> {
    let mut pgm = BufWriter::new(fs::File::create(dir.join(MAP_PGM))?);
    write!(pgm, "P5\n{} {}\n255\n", h.width, h.height)?;
    for row in rows(h, cells) {
        let bytes: Vec<u8> = row.iter().map(|&c| trinary(c)).collect();
        pgm.write_all(&bytes)?;
    }
    pgm.flush()?;

    let yaml = format!(
        "image: {MAP_PGM}\nresolution: {}\norigin: [{}, {}, {}]\nnegate: 0\n\
         occupied_thresh: {OCCUPIED_THRESH}\nfree_thresh: {FREE_THRESH}\n",
        h.resolution, h.origin_x, h.origin_y, h.origin_theta
    );
    fs::write(dir.join(MAP_YAML), yaml)?;

    let png = BufWriter::new(fs::File::create(dir.join(MAP_PNG))?);
    let mut encoder = png::Encoder::new(png, h.width, h.height);
    encoder.set_color(png::ColorType::Grayscale);
    encoder.set_depth(png::BitDepth::Eight);
    let pixels: Vec<u8> = rows(h, cells).flatten().map(|&c| shade(c)).collect();
    let mut writer = encoder.write_header().map_err(std::io::Error::other)?;
    writer
        .write_image_data(&pixels)
        .map_err(std::io::Error::other)?;
    writer.finish().map_err(std::io::Error::other)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pgm_has_map_server_values_with_the_top_row_first() {
        let dir = std::env::temp_dir().join(format!("grid-test-{}", std::process::id()));
        fs::create_dir_all(&dir).unwrap();
        let h = OccupancyGridHeader {
            resolution: 0.5,
            origin_x: -1.0,
            origin_y: 2.0,
            width: 3,
            height: 2,
            ..Default::default()
        };
        // Bottom row: unknown, free, occupied; top row: three 50 % cells.
        let cells = [-1, 10, 90, 50, 50, 50];
        write(&dir, &h, &cells).unwrap();
        let pgm = fs::read(dir.join(MAP_PGM)).unwrap();
        let header = b"P5\n3 2\n255\n";
        assert_eq!(&pgm[..header.len()], header);
        assert_eq!(&pgm[header.len()..], &[205, 205, 205, 205, 254, 0]);
        let yaml = fs::read_to_string(dir.join(MAP_YAML)).unwrap();
        assert!(
            yaml.contains("image: map.pgm") && yaml.contains("origin: [-1, 2, 0]"),
            "{yaml}"
        );
        assert!(
            yaml.contains("resolution: 0.5") && yaml.contains("negate: 0"),
            "{yaml}"
        );
        let png = fs::read(dir.join(MAP_PNG)).unwrap();
        assert_eq!(&png[1..4], b"PNG");
        let decoder = png::Decoder::new(std::io::Cursor::new(png));
        let mut reader = decoder.read_info().unwrap();
        let mut pixels = vec![0; reader.output_buffer_size().unwrap()];
        reader.next_frame(&mut pixels).unwrap();
        assert_eq!(pixels, [128, 128, 128, 205, 229, 26]);
        fs::remove_dir_all(&dir).unwrap();
    }
}
