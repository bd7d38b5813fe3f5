//! Landmark extraction judged against the simulator's truth: the simulated lidar scans
//! the shipped raw-scan worlds along their routes, the estimation library extracts poles
//! with the scenario's own service settings, and every extracted pole is compared with
//! the true poles (detection rate, false positives, centre error).

use fastslam_estimation::features::{ExtractorConfig, extract};
use fastslam_estimation::rng::seeded;
use fastslam_estimation::scan::RangeScan;
use fastslam_sensors_sim::Scenario;
use fastslam_sensors_sim::lidar_sensor::{Lidar, Target};
use fastslam_sensors_sim::vehicle::Drive;

/// An extracted pole within this distance of a true centre counts as that pole (m).
const MATCH_M: f64 = 0.5;

/// What extraction did over a drive.
#[derive(Debug)]
struct Score {
    /// True poles hit by enough beams to be extracted, summed over scans.
    detectable: usize,
    /// Of those, the ones extracted.
    detected: usize,
    /// Extracted poles near no true pole.
    false_positives: usize,
    /// Extracted poles in all.
    extracted: usize,
    /// Median distance of matched extractions from the true centre (m).
    median_error_m: f64,
}

fn score(name: &str, scans_every: u64) -> Score {
    let scenario = Scenario::load(name).unwrap();
    let spec = scenario.lidar.clone().expect("a raw-scan scenario");
    let config: ExtractorConfig = scenario
        .service
        .as_ref()
        .and_then(|s| s.get("features"))
        .map(|t| t.clone().try_into().unwrap())
        .unwrap_or_default();
    let mut lidar = Lidar::new(spec.clone(), &scenario.world, seeded(5));
    let (angle_min, angle_increment) = lidar.beam_layout();
    let dt = scenario.timing.control_period_s;
    let mut drive = Drive::new(scenario.vehicle.clone(), scenario.route.clone(), dt);
    let poles = &scenario.world.poles;
    let (mut detectable, mut detected, mut false_positives, mut extracted) = (0, 0, 0, 0);
    let mut errors = Vec::new();
    let mut step = 0_u64;
    while drive.step().is_some() {
        step += 1;
        if !step.is_multiple_of(scenario.timing.observe_every * scans_every) {
            continue;
        }
        let s = drive.state();
        let scan = lidar.scan(s);
        let ranges = &scan.data[..spec.beams as usize];
        let found = extract(
            &RangeScan {
                angle_min,
                angle_increment,
                range_min: spec.min_range_m,
                range_max: spec.max_range_m,
                ranges,
            },
            &config,
        );
        let world: Vec<[f64; 2]> = found
            .iter()
            .map(|f| {
                let a = s.theta + f.bearing;
                [s.x + f.range * a.cos(), s.y + f.range * a.sin()]
            })
            .collect();
        extracted += found.len();
        let nearest = |p: &[f64; 2]| {
            poles
                .iter()
                .enumerate()
                .map(|(i, q)| (i, (q[0] - p[0]).hypot(q[1] - p[1])))
                .min_by(|a, b| a.1.total_cmp(&b.1))
        };
        let mut seen = vec![false; poles.len()];
        for p in &world {
            match nearest(p) {
                Some((i, d)) if d < MATCH_M => {
                    seen[i] = true;
                    errors.push(d);
                }
                _ => false_positives += 1,
            }
        }
        for (i, pole) in poles.iter().enumerate() {
            let beams = scan
                .targets
                .iter()
                .filter(|t| **t == Target::Pole(i))
                .count();
            let range = (pole[0] - s.x).hypot(pole[1] - s.y);
            // Enough beams, comfortably inside the range limit.
            if beams > config.min_points && range < config.max_range - 1.0 {
                detectable += 1;
                detected += usize::from(seen[i]);
            }
        }
    }
    errors.sort_by(f64::total_cmp);
    Score {
        detectable,
        detected,
        false_positives,
        extracted,
        median_error_m: errors.get(errors.len() / 2).copied().unwrap_or(f64::NAN),
    }
}

fn check(name: &str, scans_every: u64) {
    let s = score(name, scans_every);
    println!("{name}: {s:?}");
    let rate = s.detected as f64 / s.detectable as f64;
    let false_rate = s.false_positives as f64 / s.extracted as f64;
    assert!(
        s.detectable > 100,
        "{name}: too few chances to judge: {s:?}"
    );
    assert!(rate > 0.8, "{name}: detection rate {rate:.3}: {s:?}");
    assert!(
        false_rate < 0.05,
        "{name}: false positives {false_rate:.3}: {s:?}"
    );
    assert!(s.median_error_m < 0.05, "{name}: centre error: {s:?}");
}

#[test]
fn extraction_finds_the_indoor_pillars() {
    check("indoor-loop", 1);
}

#[test]
fn extraction_finds_the_structured_worlds_poles() {
    check("structured-100m", 5);
}

#[test]
fn extraction_finds_the_webmap_poles() {
    check("bailey-poles", 3);
}
