//! `fastslam-stack extraction-report`: runs the service's pole extraction on the real
//! Victoria Park raw scans (Guivant & Nebot, ACFR; see `data/victoria_park/README.md`)
//! and compares what it finds with the tree detections released with the data set, in
//! both directions: how many of theirs it finds, how many of its own they have.

use anyhow::{Context, bail};
use fastslam_estimation::features::{ExtractorConfig, Feature, extract};
use fastslam_estimation::scan::RangeScan;
use fastslam_replay::victoria_park;
use flate2::read::GzDecoder;
use std::collections::BTreeMap;
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};

/// Flags of `extraction-report`.
#[derive(Debug, Clone, clap::Args)]
pub struct ReportArgs {
    /// Folder with `laser_raw_361beams.txt.gz` and `tree_observations.csv.gz`.
    #[arg(long, default_value = concat!(env!("CARGO_MANIFEST_DIR"), "/data/victoria_park"))]
    pub data: PathBuf,
    /// Use only the first this many scans (default: all).
    #[arg(long)]
    pub scans: Option<usize>,
    /// An extraction of ours and one of theirs in the same scan match when their centres
    /// are this close (m).
    #[arg(long, default_value_t = 1.0)]
    pub match_m: f64,
    /// Extraction settings (TOML, the `[features]` table of the service config); default:
    /// [`victoria_park_extractor`].
    #[arg(long)]
    pub config: Option<PathBuf>,
}

/// What the comparison found.
#[derive(Debug, Clone, PartialEq)]
pub struct Comparison {
    /// Raw scans used.
    pub scans: usize,
    /// Released detections in those scans.
    pub theirs: usize,
    /// Our detections in those scans.
    pub ours: usize,
    /// Matched pairs (one-to-one per scan).
    pub matched: usize,
    /// Median centre distance of the matched pairs (m).
    pub median_error_m: f64,
    /// Median of |our diameter − theirs| over the matched pairs (m).
    pub median_diameter_error_m: f64,
}

/// The extraction settings for the SICK LMS of Victoria Park: trees up to 80 m, runs of a
/// single return accepted (far trunks cover one 0.5° beam; the released detections
/// include them), diameters up to 1.5 m.
pub fn victoria_park_extractor() -> ExtractorConfig {
    ExtractorConfig {
        max_range: 80.0,
        min_points: 1,
        min_diameter: 0.0,
        max_diameter: 1.5,
        max_rms: 0.1,
        ..ExtractorConfig::default()
    }
}

/// A centre in the scanner's frame (REP-103: x forward, y left), m.
fn centre(range: f64, bearing: f64) -> [f64; 2] {
    [range * bearing.cos(), range * bearing.sin()]
}

/// Runs the comparison.
///
/// # Errors
/// When a file cannot be read or a line cannot be parsed (the line is named).
pub fn compare(args: &ReportArgs) -> anyhow::Result<Comparison> {
    let config = match &args.config {
        Some(path) => {
            let text = std::fs::read_to_string(path)
                .with_context(|| format!("reading {}", path.display()))?;
            let config: ExtractorConfig =
                toml::from_str(&text).with_context(|| format!("parsing {}", path.display()))?;
            config.validate()?;
            config
        }
        None => victoria_park_extractor(),
    };
    let (mut scans, skipped) = victoria_park::read_raw_scans(&args.data)?;
    if let Some(skipped) = skipped {
        eprintln!("warning: {skipped}");
    }
    scans.truncate(args.scans.unwrap_or(usize::MAX));
    let mut trees = read_trees(&args.data.join("tree_observations.csv.gz"))?;
    let increment = 0.5f64.to_radians();
    let (mut theirs, mut ours, mut errors, mut diameters) = (0, 0, Vec::new(), Vec::new());
    for (index, raw) in scans.iter().enumerate() {
        let scan = RangeScan {
            angle_min: -std::f64::consts::FRAC_PI_2,
            angle_increment: increment,
            range_min: 0.0,
            range_max: f64::from(victoria_park::NO_RETURN_M),
            ranges: &raw.ranges,
        };
        let found = extract(&scan, &config);
        let released = trees.remove(&index).unwrap_or_default();
        theirs += released.len();
        ours += found.len();
        for (a, b) in match_pairs(&found, &released, args.match_m) {
            let (f, t) = (&found[a], &released[b]);
            let p = centre(f.range, f.bearing);
            let q = centre(t.range, t.bearing);
            errors.push((p[0] - q[0]).hypot(p[1] - q[1]));
            diameters.push((f.diameter - t.diameter).abs());
        }
    }
    Ok(Comparison {
        scans: scans.len(),
        theirs,
        ours,
        matched: errors.len(),
        median_error_m: median(&mut errors),
        median_diameter_error_m: median(&mut diameters),
    })
}

/// Prints the comparison.
///
/// # Errors
/// As [`compare`].
pub fn run(args: &ReportArgs) -> anyhow::Result<()> {
    let c = compare(args)?;
    let percent = |n: usize, of: usize| 100.0 * n as f64 / of.max(1) as f64;
    println!(
        "Victoria Park (Guivant & Nebot, ACFR): {} raw scans, {} beams over 0°…180°, \
         81.91 m = no return",
        c.scans,
        victoria_park::BEAMS
    );
    println!("  released tree detections   {:>6}", c.theirs);
    println!("  our pole extractions       {:>6}", c.ours);
    println!(
        "  theirs we find             {:>6}   ({:.1} %, centres within {} m)",
        c.matched,
        percent(c.matched, c.theirs),
        args.match_m
    );
    println!(
        "  ours they have             {:>6}   ({:.1} %)",
        c.matched,
        percent(c.matched, c.ours)
    );
    println!("  median centre error        {:>8.3} m", c.median_error_m);
    println!(
        "  median diameter difference {:>8.3} m",
        c.median_diameter_error_m
    );
    Ok(())
}

/// One-to-one pairs (ours, theirs) of one scan within `gate` metres, closest first.
fn match_pairs(ours: &[Feature], theirs: &[Feature], gate: f64) -> Vec<(usize, usize)> {
    let mut candidates: Vec<(f64, usize, usize)> = Vec::new();
    for (a, f) in ours.iter().enumerate() {
        for (b, t) in theirs.iter().enumerate() {
            let (p, q) = (centre(f.range, f.bearing), centre(t.range, t.bearing));
            let d = (p[0] - q[0]).hypot(p[1] - q[1]);
            if d <= gate {
                candidates.push((d, a, b));
            }
        }
    }
    candidates.sort_by(|x, y| x.0.total_cmp(&y.0));
    let (mut used_a, mut used_b) = (vec![false; ours.len()], vec![false; theirs.len()]);
    let mut pairs = Vec::new();
    for (_, a, b) in candidates {
        if !used_a[a] && !used_b[b] {
            (used_a[a], used_b[b]) = (true, true);
            pairs.push((a, b));
        }
    }
    pairs
}

fn median(values: &mut [f64]) -> f64 {
    values.sort_by(f64::total_cmp);
    values.get(values.len() / 2).copied().unwrap_or(f64::NAN)
}

fn lines(path: &Path) -> anyhow::Result<impl Iterator<Item = (usize, std::io::Result<String>)>> {
    let file = std::fs::File::open(path).with_context(|| format!("opening {}", path.display()))?;
    Ok(BufReader::new(GzDecoder::new(file)).lines().enumerate())
}

/// The released detections by scan index, as features in our bearing convention.
fn read_trees(path: &Path) -> anyhow::Result<BTreeMap<usize, Vec<Feature>>> {
    let mut trees: BTreeMap<usize, Vec<Feature>> = BTreeMap::new();
    for (n, line) in lines(path)?.skip(1) {
        let line = line.with_context(|| format!("{}: line {}", path.display(), n + 1))?;
        let bad = || format!("{}: line {}: `{line}`", path.display(), n + 1);
        let fields: Vec<&str> = line.split(',').collect();
        let [_, index, range, bearing, diameter] = fields[..] else {
            bail!("{}: expected 5 fields", bad());
        };
        let index: usize = index.trim().parse().with_context(bad)?;
        let number = |s: &str| s.trim().parse::<f64>().with_context(bad);
        trees.entry(index).or_default().push(Feature {
            range: number(range)?,
            bearing: number(bearing)? - std::f64::consts::FRAC_PI_2,
            diameter: number(diameter)?,
            points: 0,
            rms: 0.0,
        });
    }
    Ok(trees)
}
