//! An offline check of the grid-SLAM loop-closing back-end on a CARMEN log. A front end
//! turns the log into keyframes — the raw odometry poses (`odometry`, keyframes every
//! 0.5 m or 15°), or grid FastSLAM driven by the odometry increments (`gridslam[:N]`, N
//! particles, its own keyframes and estimate covariance) — and the back-end matches,
//! closes loops and solves as the service would drive it. Prints the loop closures found
//! and accepted, the time per keyframe and per solve, how much each solve changed the
//! correction, and, when `<name>.relations` sits next to the log, the Freiburg relation
//! errors of the front end, of the real-time pose the service would publish (the front
//! end's moved by the correction `delay_keyframes` keyframes old, in the map frame's gauge
//! `loop_closure::local_gauge`) and of the back-end's
//! trajectory (every scan placed as the service places it, `loop_closure::place_scans`).
//! Writes the back-end's map as a PGM image.
//!
//! ```text
//! cargo run --release -p fastslam-replay --example loop_closure_carmen -- \
//!     data/freiburg/intel/intel.clf.gz [odometry|gridslam[:N]] [map.pgm]
//! ```

use fastslam_estimation::fastslam::FastSlamConfig;
use fastslam_estimation::grid::GridConfig;
use fastslam_estimation::gridslam::{GridFastSlam, ScanMatchConfig};
use fastslam_estimation::loop_closure::{
    Keyframe, LoopClosureConfig, Odometry, OdometryFit, PoseGraphMapper, Solution, local_gauge,
    place_scans,
};
use fastslam_estimation::motion::{Control, Increment, MotionModel};
use fastslam_estimation::moves::MoveConfig;
use fastslam_estimation::optimise::{OptimiserConfig, OptimiserKind};
use fastslam_estimation::scan::{Beam, RangeScan};
use fastslam_estimation::{Pose2, wrap_angle};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// What a front end says at a scan: its pose, its pose before the scan was matched, and
/// when the scan is a keyframe, the covariance of the motion since the previous keyframe
/// and the odometry's account of that motion (grid FastSLAM's; none for the odometry
/// front end, whose motion is the odometry's).
type Estimate = (Pose2, Pose2, Option<[[f64; 3]; 3]>, Option<Odometry>);

/// Where the keyframes come from.
enum FrontEnd {
    /// Raw odometry, a keyframe every 0.5 m or 15°; covariance from GMapping's odometry
    /// noise over the motion since the last keyframe.
    Odometry { last: Option<Pose2> },
    /// Grid FastSLAM with the increment motion model.
    GridSlam(Box<GridFastSlam>),
}

impl FrontEnd {
    /// Takes the odometry increment since the previous scan and the scan.
    fn step(&mut self, odometry: &Pose2, increment: &Pose2, scan: &RangeScan<'_>) -> Estimate {
        match self {
            Self::Odometry { last } => {
                let moved = last.map(|l| l.inverse().compose(odometry));
                let due = moved.is_none_or(|d| d.x.hypot(d.y) >= 0.5 || d.theta.abs() >= 0.2618);
                if !due {
                    return (*odometry, *odometry, None, None);
                }
                *last = Some(*odometry);
                let d = moved.unwrap_or_default();
                let (dist, turn) = (d.x.hypot(d.y), d.theta.abs());
                let (vxy, vt) = (0.01 * dist + 0.01 * turn, 0.04 * dist + 0.04 * turn);
                let c = [[vxy, 0.0, 0.0], [0.0, vxy, 0.0], [0.0, 0.0, vt]];
                (*odometry, *odometry, Some(c), None)
            }
            Self::GridSlam(slam) => {
                let control = Control {
                    increment: *increment,
                    ..Control::ZERO
                };
                slam.predict(&control, 0.1).expect("a finite increment");
                let predicted = slam.estimate().mean;
                let odometry = Odometry {
                    predicted,
                    covariance: slam.motion_prior(),
                };
                let step = slam.observe(scan).expect("weights stay finite");
                let e = slam.estimate();
                let c = e.covariance;
                let covariance = std::array::from_fn(|i| std::array::from_fn(|j| c[(i, j)]));
                let keyframe = step.keyframe;
                (
                    e.mean,
                    predicted,
                    keyframe.then_some(covariance),
                    keyframe.then_some(odometry),
                )
            }
        }
    }
}

fn main() -> anyhow::Result<()> {
    let mut args = std::env::args().skip(1);
    let path = PathBuf::from(
        args.next()
            .unwrap_or_else(|| "data/freiburg/intel/intel.clf.gz".into()),
    );
    let front = args.next().unwrap_or_else(|| "odometry".into());
    let image = PathBuf::from(
        args.next()
            .unwrap_or_else(|| "/tmp/loop_closure_map.pgm".into()),
    );
    let log = fastslam_replay::carmen::load(&path)?;
    println!("{log}");
    for warning in &log.warnings {
        println!("warning: {warning}");
    }
    let data = &log.data;
    let odometry: Vec<(u64, Pose2)> = (data.odometry.iter())
        .map(|o| (o.header.stamp_ns, Pose2::new(o.x, o.y, o.theta)))
        .collect();
    let grid = GridConfig {
        resolution: 0.05,
        ..GridConfig::default()
    };
    let mut front_end = match front.split_once(':').map_or((front.as_str(), "30"), |p| p) {
        ("odometry", _) => FrontEnd::Odometry { last: None },
        ("gridslam", n) => {
            let filter = FastSlamConfig {
                particles: n.parse()?,
                seed: 1,
                motion: MotionModel::Increment(Increment::default()),
                ..FastSlamConfig::default()
            };
            let optimiser = OptimiserConfig {
                kind: OptimiserKind::Hill,
                ..OptimiserConfig::default()
            };
            let matcher = ScanMatchConfig::default();
            let mut slam = GridFastSlam::new(
                filter,
                grid.clone(),
                matcher,
                &optimiser,
                MoveConfig::default(),
            )?;
            slam.set_laser_mount(data.laser_mount);
            FrontEnd::GridSlam(Box::new(slam))
        }
        (other, _) => anyhow::bail!("unknown front end `{other}`"),
    };
    let config = LoopClosureConfig::default();
    let mut mapper = PoseGraphMapper::new(config.clone())?;
    let (mut found, mut solves, mut solve_s, mut add_s, mut worst_add) = (0, 0, 0.0, 0.0, 0.0f64);
    let mut latest: Option<Solution> = None;
    // (stamp, front end's pose, keyframe before it) of every scan; the front end's pose
    // at each keyframe.
    let mut scans: Vec<(u64, Pose2, usize)> = Vec::new();
    let (mut keyframe_poses, mut predicted): (Vec<Pose2>, Vec<Pose2>) = (Vec::new(), Vec::new());
    // The correction in force after each keyframe, and every scan's real-time pose: the
    // front end's moved by the correction of `delay_keyframes` keyframes before.
    let mut corrections: Vec<Pose2> = Vec::new();
    let mut real_time: Vec<(u64, Pose2)> = Vec::new();
    // At each solve: the change of the correction, and the first keyframe's move in the
    // map frame (the gauge's change), translation (m) and heading (°).
    let mut jumps: Vec<(f64, f64)> = Vec::new();
    let mut moves: Vec<(f64, f64)> = Vec::new();
    // The real-time pose at each keyframe, and the map frame's gauge of the newest solve.
    let mut published: Vec<Pose2> = Vec::new();
    let mut gauge = Pose2::default();
    let mut front_s = 0.0;
    let mut previous: Option<Pose2> = None;
    let started = Instant::now();
    for raw in &data.raw_scans {
        let stamp = raw.header.header.stamp_ns;
        let Some(pose) = pose_at(&odometry, stamp) else {
            continue;
        };
        let increment = previous.map_or_else(Pose2::default, |p| p.inverse().compose(&pose));
        previous = Some(pose);
        let h = &raw.header;
        let scan = RangeScan {
            angle_min: f64::from(h.angle_min),
            angle_increment: f64::from(h.angle_increment),
            range_min: f64::from(h.range_min),
            range_max: f64::from(h.range_max),
            ranges: &raw.items,
        };
        let t0 = Instant::now();
        let (estimate, before_match, covariance, odometry) =
            front_end.step(&pose, &increment, &scan);
        front_s += t0.elapsed().as_secs_f64();
        if let Some(c) = covariance {
            let mount = data.laser_mount;
            let points = (0..scan.len())
                .filter_map(|i| match scan.beam(i) {
                    Beam::Hit(r) if r <= config.max_range => {
                        let a = scan.angle(i);
                        let p = mount.compose(&Pose2::new(r * a.cos(), r * a.sin(), 0.0));
                        Some([p.x, p.y])
                    }
                    _ => None,
                })
                .collect();
            let mut keyframe = Keyframe {
                stamp_ns: stamp,
                pose: estimate,
                covariance: Default::default(),
                points,
                beams: grid.kept_beams(&scan),
                sensor: mount,
                odometry,
            };
            for (i, row) in c.iter().enumerate() {
                for (j, v) in row.iter().enumerate() {
                    keyframe.covariance[(i, j)] = *v;
                }
            }
            let t0 = Instant::now();
            let report = mapper.add_keyframe(keyframe)?;
            let dt = t0.elapsed().as_secs_f64();
            add_s += dt;
            worst_add = worst_add.max(dt);
            found += report.closures.len();
            keyframe_poses.push(estimate);
            predicted.push(before_match);
            if report.solve_due {
                let solution = mapper.solve()?;
                solves += 1;
                solve_s += solution.seconds;
                let old_gauge = gauge;
                let radius = config.gauge_radius;
                gauge = local_gauge(&solution.poses, &published, radius).unwrap_or(gauge);
                // The first keyframe, which its prior holds in the graph, moves with the gauge.
                let first = solution.poses.first().copied().unwrap_or_default();
                let (moved, was) = (gauge.compose(&first), old_gauge.compose(&first));
                let turn = wrap_angle(moved.theta - was.theta).abs().to_degrees();
                moves.push(((moved.x - was.x).hypot(moved.y - was.y), turn));
                let before = corrections.last().copied().unwrap_or_default();
                let d = before
                    .inverse()
                    .compose(&gauge.compose(&solution.correction));
                jumps.push((d.x.hypot(d.y), d.theta.abs().to_degrees()));
                latest = Some(solution);
            }
            corrections.push(gauge.compose(&mapper.correction()));
        }
        let in_force = (corrections.len().checked_sub(1 + config.delay_keyframes))
            .map_or_else(Pose2::default, |k| corrections[k]);
        let in_map = in_force.compose(&estimate);
        real_time.push((stamp, in_map));
        if covariance.is_some() {
            published.push(in_map);
        }
        if let Some(k) = mapper.keyframes().checked_sub(1) {
            scans.push((stamp, estimate, k));
        }
    }
    // The last solve, with the odometry's weight fitted to the solution, as the service's.
    let finished = mapper.finish();
    if let Some(e) = finished.failed {
        return Err(e.into());
    }
    match finished.odometry {
        OdometryFit::Weighted(fit) => println!(
            "last solve: odometry constraints weighted ×{:.2} (variance factors: \
             odometry {:.3}, the rest {:.3})",
            fit.weight, fit.odometry.scale, fit.rest.scale
        ),
        OdometryFit::Off | OdometryFit::Unfitted => {
            println!("last solve: odometry constraints at the model's weight")
        }
    }
    solves += finished.solutions.len();
    solve_s += finished.solutions.iter().map(|s| s.seconds).sum::<f64>();
    let Some(solution) = finished.solutions.into_iter().last().or(latest) else {
        anyhow::bail!("no solve: the log gave no keyframe");
    };
    let total = started.elapsed().as_secs_f64();
    let n = mapper.keyframes();
    println!(
        "front end `{front}`: {:.1} s; {n} keyframes, {} submaps; loop closures found {found}, \
         accepted {} of {} at the end; back-end {:.1} ms per keyframe (worst {:.0} ms), \
         {solves} solves of {:.0} ms on average; {:.1} s in all; {:.0} MB of submaps, beams and points",
        front_s,
        mapper.submaps().len(),
        solution.accepted,
        solution.closures,
        1e3 * add_s / n as f64,
        1e3 * worst_add,
        1e3 * solve_s / solves as f64,
        total,
        mapper.bytes() as f64 / 1e6,
    );
    match (mapper.graph()).between_components(&|_, b| b.to != b.from + 1) {
        Ok([chain, loops]) => println!(
            "variance factors: consecutive {:.3} (redundancy {:.0} of {}), loop closures {:.3} \
             (redundancy {:.0} of {})",
            chain.scale,
            chain.redundancy,
            chain.residuals,
            loops.scale,
            loops.redundancy,
            loops.residuals
        ),
        Err(e) => println!("variance factors: {e}"),
    }
    // Every scan's pose, placed between its two keyframes' optimised poses.
    let motion = MotionModel::Increment(Increment::default());
    let placed = place_scans(
        &scans
            .iter()
            .map(|&(_, pose, k)| (pose, k))
            .collect::<Vec<_>>(),
        &keyframe_poses,
        &predicted,
        mapper.poses(),
        &mapper.correction(),
        |delta| motion.path_variances(delta),
    );
    let optimised: Vec<(u64, Pose2)> = (scans.iter().zip(placed))
        .map(|(&(stamp, _, _), pose)| (stamp, pose))
        .collect();
    let own: Vec<(u64, Pose2)> = scans.iter().map(|&(s, p, _)| (s, p)).collect();
    print_changes("correction changes", &mut jumps);
    print_changes("the first keyframe's moves", &mut moves);
    if let Some(first) = mapper.poses().first() {
        let moved = gauge.compose(first);
        println!(
            "the first keyframe ends {:.2} m and {:.2}° from where the graph's prior holds it",
            (moved.x - first.x).hypot(moved.y - first.y),
            wrap_angle(moved.theta - first.theta).abs().to_degrees()
        );
    }
    if let Some(relations) = relations_of(&path) {
        let relations = std::fs::read_to_string(&relations)?;
        for (name, track) in [
            ("front end", &own),
            ("real time", &real_time),
            ("back-end", &optimised),
        ] {
            if let Some((t, r, count)) = score(&relations, track, data.epoch_s) {
                println!(
                    "{name}: relation errors over {count}: translation {:.3} ± {:.3} m, \
                     rotation {:.2} ± {:.2}°",
                    t.0, t.1, r.0, r.1
                );
            }
        }
    }
    // The final map, as the service renders it: in the first keyframe's frame.
    if let Some(map) = mapper.render(&grid, &Pose2::default()) {
        let mut bytes = format!("P5\n{} {}\n255\n", map.width, map.height).into_bytes();
        for j in (0..map.height).rev() {
            for i in 0..map.width {
                let c = map.cells[j * map.width + i];
                bytes.push(if c < 0 {
                    205
                } else {
                    (255 - 255 * i32::from(c) / 100) as u8
                });
            }
        }
        std::fs::write(&image, bytes)?;
        println!("map written to {}", image.display());
    }
    Ok(())
}

/// Prints the median and worst of `changes` (translation in m, heading in °), each sorted
/// on its own, with how many turn by more than 0.5°.
fn print_changes(what: &str, changes: &mut [(f64, f64)]) {
    let (mut moves, mut turns): (Vec<f64>, Vec<f64>) = changes.iter().copied().unzip();
    if moves.is_empty() {
        return;
    }
    moves.sort_by(f64::total_cmp);
    turns.sort_by(f64::total_cmp);
    let big = turns.iter().filter(|&&t| t > 0.5).count();
    let (n, half) = (moves.len(), moves.len() / 2);
    println!(
        "{what} at {n} solves: median {:.3} m and {:.3}°, worst {:.2} m and {:.2}°, {big} over 0.5°",
        moves[half],
        turns[half],
        moves[n - 1],
        turns[n - 1]
    );
}

/// The odometry pose at `stamp`, interpolated between the poses around it.
fn pose_at(odometry: &[(u64, Pose2)], stamp: u64) -> Option<Pose2> {
    let k = odometry.partition_point(|(s, _)| *s < stamp);
    let (s1, p1) = *odometry.get(k)?;
    if s1 == stamp || k == 0 {
        return (s1 == stamp).then_some(p1);
    }
    let (s0, p0) = odometry[k - 1];
    let f = (stamp - s0) as f64 / (s1 - s0) as f64;
    Some(Pose2::new(
        p0.x + f * (p1.x - p0.x),
        p0.y + f * (p1.y - p0.y),
        p0.theta + f * wrap_angle(p1.theta - p0.theta),
    ))
}

/// `<dir>/<name>.relations` for `<dir>/<name>.clf[.gz]`, when it exists.
fn relations_of(log: &Path) -> Option<PathBuf> {
    let name = log.file_name()?.to_str()?;
    let stem = name.split('.').next()?;
    let path = log.with_file_name(format!("{stem}.relations"));
    path.exists().then_some(path)
}

/// Mean and standard deviation of the translational (m) and rotational (°) relation
/// errors, and how many relations were scored.
type Scores = ((f64, f64), (f64, f64), usize);

/// Mean ± standard deviation of the relation errors (translation m, rotation °) of
/// `track` against the Freiburg relations in `text` (times on the log's clock), each end
/// taken from the nearest pose within 0.1 s; and how many relations were scored.
fn score(text: &str, track: &[(u64, Pose2)], epoch_s: f64) -> Option<Scores> {
    let nearest = |t: f64| -> Option<Pose2> {
        let stamp = ((t - epoch_s) * 1e9).round();
        if stamp < 0.0 {
            return None;
        }
        let stamp = stamp as u64;
        let k = track.partition_point(|(s, _)| *s < stamp);
        let candidates = [k.checked_sub(1), Some(k)];
        let (s, p) = (candidates.iter().flatten())
            .filter_map(|&i| track.get(i))
            .min_by_key(|(s, _)| s.abs_diff(stamp))?;
        (s.abs_diff(stamp) <= 100_000_000).then_some(*p)
    };
    let (mut translation, mut rotation) = (Vec::new(), Vec::new());
    for line in text.lines() {
        let f: Vec<f64> = line
            .split_ascii_whitespace()
            .filter_map(|v| v.parse().ok())
            .collect();
        if f.len() < 8 {
            continue;
        }
        let (Some(a), Some(b)) = (nearest(f[0]), nearest(f[1])) else {
            continue;
        };
        let d = a.inverse().compose(&b);
        translation.push((d.x - f[2]).hypot(d.y - f[3]));
        rotation.push(wrap_angle(d.theta - f[7]).abs().to_degrees());
    }
    let stats = |v: &[f64]| {
        let n = v.len() as f64;
        let mean = v.iter().sum::<f64>() / n;
        let var = v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0).max(1.0);
        (mean, var.sqrt())
    };
    (!translation.is_empty()).then(|| (stats(&translation), stats(&rotation), translation.len()))
}
