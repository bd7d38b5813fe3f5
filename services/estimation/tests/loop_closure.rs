//! The loop-closing back-end of grid SLAM on synthetic worlds: branch and bound against an
//! exhaustive search, a square corridor loop driven with heading-biased odometry, a wrong
//! loop closure, and bit-for-bit determinism across thread counts.

mod common;

use common::{Segment, beam_angle, corridor_world, scan};
use fastslam_estimation::Pose2;
use fastslam_estimation::grid::{GridConfig, KeptBeam, LogOddsGrid, OccupancyGrid};
use fastslam_estimation::loop_closure::{
    Keyframe, LoopClosure, LoopClosureConfig, MatchGrid, PoseGraphMapper, ProbabilityGrid,
    SearchWindow, local_gauge,
};
use fastslam_estimation::rng::seeded;
use nalgebra::Matrix3;
use rand::RngExt;
use rand_distr::StandardNormal;
use std::time::Instant;

/// The simulated laser's range (m).
const MAX_RANGE: f64 = 12.0;

/// Beams (returns within `MAX_RANGE`, the rest as free beams of that length) and every
/// second return as a point, sensor = base.
fn beams_and_points(ranges: &[f64]) -> (Vec<KeptBeam>, Vec<[f64; 2]>) {
    let mut beams = Vec::new();
    let mut points = Vec::new();
    for (i, &r) in ranges.iter().enumerate() {
        let a = beam_angle(i);
        let hit = r < MAX_RANGE;
        let length = r.min(MAX_RANGE);
        beams.push(KeptBeam {
            angle: a as f32,
            length: length as f32,
            hit,
        });
        if hit && i % 2 == 0 {
            points.push([r * a.cos(), r * a.sin()]);
        }
    }
    (beams, points)
}

/// True keyframe poses `laps` times around the ring: 0.5 m steps along each side, 30°
/// turns at the corners, and `extra` steps along the first side again.
fn loop_path(laps: usize, extra: usize) -> Vec<Pose2> {
    let mut path = Vec::new();
    let mut pose = Pose2::default();
    let sides = 4 * laps;
    for side in 0..=sides {
        let steps = if side == sides { extra } else { 20 };
        for _ in 0..steps {
            path.push(pose);
            pose = pose.compose(&Pose2::new(0.5, 0.0, 0.0));
        }
        if side < sides {
            for _ in 0..3 {
                path.push(pose);
                pose = pose.compose(&Pose2::new(0.0, 0.0, 30f64.to_radians()));
            }
        }
    }
    path.push(pose);
    path
}

/// The front end's poses along `truth`: each relative motion with a heading bias of
/// `bias` (rad per keyframe) plus `turn_scale` times its turn, and small noise.
fn drifting_front_end(truth: &[Pose2], bias: f64, turn_scale: f64, seed: u64) -> Vec<Pose2> {
    let mut rng = seeded(seed);
    let mut normal = || rng.sample::<f64, _>(StandardNormal);
    let mut out = vec![truth[0]];
    for w in truth.windows(2) {
        let d = w[0].inverse().compose(&w[1]);
        let noisy = Pose2::new(
            d.x + 0.005 * normal(),
            d.y + 0.005 * normal(),
            d.theta * (1.0 + turn_scale) + bias + 0.0005 * normal(),
        );
        let last = *out.last().expect("started");
        out.push(last.compose(&noisy));
    }
    out
}

fn test_config() -> LoopClosureConfig {
    LoopClosureConfig {
        keyframes_per_submap: 15,
        ..LoopClosureConfig::default()
    }
}

/// The keyframes of the ring loop: truth, front end, and the keyframes as handed over.
struct Run {
    truth: Vec<Pose2>,
    front_end: Vec<Pose2>,
    keyframes: Vec<Keyframe>,
}

fn ring_run() -> Run {
    drifting_ring(0.05, 0.1, 1)
}

/// The ring loop driven `laps` times with a heading bias of `bias_deg` (degrees per
/// keyframe), each keyframe's heading σ `sigma_deg` plus 5 % of its turn.
fn drifting_ring(bias_deg: f64, sigma_deg: f64, laps: usize) -> Run {
    let world = corridor_world();
    let truth = loop_path(laps, 16);
    let front_end = drifting_front_end(&truth, bias_deg.to_radians(), 0.02, 7);
    let keyframes = (truth.iter().zip(&front_end).enumerate())
        .map(|(k, (t, f))| {
            let (beams, points) = beams_and_points(&scan(&world, t, 0.01, 100 + k as u64));
            // Odometry's heading uncertainty grows with the turn: 5 % of it, plus σ.
            let turned = k.checked_sub(1).map_or(0.0, |p| {
                fastslam_estimation::wrap_angle(front_end[k].theta - front_end[p].theta)
            });
            let sigma_theta = sigma_deg.to_radians() + 0.05 * turned.abs();
            Keyframe {
                stamp_ns: k as u64 * 1_000_000_000,
                pose: *f,
                covariance: Matrix3::from_diagonal(&nalgebra::Vector3::new(
                    1e-4,
                    1e-4,
                    sigma_theta * sigma_theta,
                )),
                points,
                beams,
                sensor: Pose2::default(),
                odometry: None,
            }
        })
        .collect();
    Run {
        truth,
        front_end,
        keyframes,
    }
}

/// Feeds `keyframes` to a fresh mapper, solving whenever one is due and once at the end;
/// `inject` may add closures after keyframe `k` is in.
fn drive(
    config: LoopClosureConfig,
    keyframes: &[Keyframe],
    mut inject: impl FnMut(usize, &mut PoseGraphMapper),
) -> PoseGraphMapper {
    let mut mapper = PoseGraphMapper::new(config).unwrap();
    for (k, keyframe) in keyframes.iter().enumerate() {
        let report = mapper.add_keyframe(keyframe.clone()).unwrap();
        inject(k, &mut mapper);
        if report.solve_due || mapper.solve_due() {
            mapper.solve().unwrap();
        }
    }
    mapper.solve().unwrap();
    mapper
}

fn distance(a: &Pose2, b: &Pose2) -> f64 {
    (a.x - b.x).hypot(a.y - b.y)
}

/// Occupied cells (≥ 65 %) in a strip ±1.5 m across the wall `y = wall` for `x` in `xs`, and how
/// far the farthest lies from the wall (m).
fn wall_spread(grid: &OccupancyGrid, wall: f64, xs: (f64, f64)) -> (usize, f64) {
    let r = grid.resolution;
    let (mut count, mut worst) = (0, 0.0f64);
    let mut x = xs.0;
    while x < xs.1 {
        let mut y = wall - 1.5;
        while y < wall + 1.5 {
            let i = ((x - grid.origin[0]) / r).floor() as usize;
            let j = ((y - grid.origin[1]) / r).floor() as usize;
            if i < grid.width && j < grid.height && grid.cells[j * grid.width + i] >= 65 {
                let centre = grid.origin[1] + (j as f64 + 0.5) * r;
                count += 1;
                worst = worst.max((centre - wall).abs());
            }
            y += r;
        }
        x += r;
    }
    (count, worst)
}

/// A submap's matching grids from scans of `world` taken at `poses`, each inserted
/// `repeats` times with the back-end's inverse sensor model.
fn submap_from(world: &[Segment], poses: &[Pose2], repeats: usize, noise: f64) -> MatchGrid {
    let config = test_config();
    let insertion = GridConfig {
        resolution: config.resolution,
        l_occupied: config.l_occupied,
        l_free: config.l_free,
        l_min: -config.l_clamp,
        l_max: config.l_clamp,
        ..GridConfig::default()
    };
    let mut grid = LogOddsGrid::new(config.resolution, [-8.0, -8.0], 640, 640);
    for (k, pose) in poses.iter().enumerate() {
        let (beams, _) = beams_and_points(&scan(world, pose, noise, k as u64));
        for _ in 0..repeats {
            grid.integrate(pose, &beams, &insertion);
        }
    }
    MatchGrid::new(ProbabilityGrid::from_occupancy(&grid.occupancy(), 50), 7)
}

/// The poses of a submap along the ring's first side, 0.5 m apart.
fn first_side(count: usize) -> Vec<Pose2> {
    (0..count)
        .map(|k| Pose2::new(0.5 * k as f64, 0.0, 0.0))
        .collect()
}

/// A submap of the ring's first corner, seen from five poses, a scan's points taken in
/// it and the scan's true pose.
fn first_corner() -> (MatchGrid, Vec<[f64; 2]>, Pose2) {
    let world = corridor_world();
    let poses: Vec<Pose2> = (0..5)
        .map(|k| Pose2::new(6.0 + 0.8 * k as f64, 0.1 * k as f64, 0.05 * k as f64))
        .collect();
    let submap = submap_from(&world, &poses, 3, 0.0);
    let truth = Pose2::new(8.3, 0.2, 0.07);
    let (_, points) = beams_and_points(&scan(&world, &truth, 0.01, 99));
    (submap, points, truth)
}

#[test]
fn branch_and_bound_finds_a_known_offset_with_the_exhaustive_best_score() {
    let (submap, points, truth) = first_corner();
    let initial = Pose2::new(truth.x - 0.37, truth.y + 0.52, truth.theta - 0.12);
    let window = SearchWindow {
        linear: 1.0,
        angular: 10f64.to_radians(),
    };
    let bnb = submap.match_scan(&points, &initial, &window, 0.0).unwrap();
    let all = submap
        .match_exhaustive(&points, &initial, &window, 0.0)
        .unwrap();
    assert_eq!(bnb.score, all.score, "{bnb:?} vs {all:?}");
    assert!(bnb.score > 0.6, "{bnb:?}");
    let err = distance(&bnb.pose, &truth);
    let turn = (bnb.pose.theta - truth.theta).abs();
    println!(
        "offset found: error {:.4} m, {:.3}° (lattice {:.4} m), score {:.3}",
        err,
        turn.to_degrees(),
        distance(&bnb.coarse, &truth),
        bnb.score
    );
    assert!(err < 0.05 && turn < 0.01, "{bnb:?}");
    // Nothing reaches a score of 0.99.
    assert!(
        submap
            .match_scan(&points, &initial, &window, 0.99)
            .is_none()
    );
}

#[test]
fn a_match_in_a_wide_window_takes_milliseconds() {
    let world = corridor_world();
    let started = Instant::now();
    let submap = submap_from(&world, &first_side(15), 1, 0.01);
    let precompute = started.elapsed().as_secs_f64();
    let truth = Pose2::new(3.2, 0.1, 0.03);
    let ranges = scan(&world, &truth, 0.01, 5);
    let window = SearchWindow {
        linear: 3.0,
        angular: 20f64.to_radians(),
    };
    for stride in [2, 1] {
        let points: Vec<[f64; 2]> = (ranges.iter().enumerate())
            .filter(|(i, r)| i % stride == 0 && **r < MAX_RANGE)
            .map(|(i, r)| [r * beam_angle(i).cos(), r * beam_angle(i).sin()])
            .collect();
        let initial = Pose2::new(truth.x + 1.1, truth.y - 0.4, truth.theta + 0.15);
        let mut times = Vec::new();
        let mut found = None;
        for _ in 0..5 {
            let t = Instant::now();
            found = submap.match_scan(&points, &initial, &window, 0.5);
            times.push(t.elapsed().as_secs_f64());
        }
        times.sort_by(f64::total_cmp);
        let found = found.expect("the scan matches");
        println!(
            "{} points, ±3 m ±20° at 5 cm, {} × {} cells: {:.2} ms per match (median of 5), \
             {:.1} ms to precompute {} levels, {:.1} MB; error {:.3} m, score {:.3}",
            points.len(),
            submap.probabilities().width(),
            submap.probabilities().height(),
            1e3 * times[2],
            1e3 * precompute,
            submap.depth(),
            submap.bytes() as f64 / 1e6,
            distance(&found.pose, &truth),
            found.score
        );
        assert!(distance(&found.pose, &truth) < 0.05);
    }
}

#[test]
fn a_scan_scores_higher_in_its_own_corridor_than_in_a_similar_one() {
    let world = corridor_world();
    let submap = submap_from(&world, &first_side(15), 1, 0.01);
    let window = SearchWindow {
        linear: 3.0,
        angular: 20f64.to_radians(),
    };
    let (_, here) = beams_and_points(&scan(&world, &Pose2::new(3.2, 0.0, 0.0), 0.01, 1));
    let right = submap
        .match_scan(&here, &Pose2::new(3.2, 0.0, 0.0), &window, 0.0)
        .unwrap();
    // The third side's corridor, 3.2 m along it, looks like the first but for its boxes.
    let (_, elsewhere) = beams_and_points(&scan(
        &world,
        &Pose2::new(6.8, 10.0, std::f64::consts::PI),
        0.01,
        2,
    ));
    let wrong = submap
        .match_scan(&elsewhere, &Pose2::new(3.2, 0.0, 0.0), &window, 0.0)
        .unwrap();
    println!(
        "the right corridor scores {:.3}, the wrong one at best {:.3} (min_score {})",
        right.score,
        wrong.score,
        test_config().min_score
    );
    // Long walls carry most points: the score tells the corridors apart, but not by
    // enough for `min_score` alone to refuse the wrong one — the search window and the
    // robust solve have to.
    assert!(right.score >= test_config().min_score);
    assert!(right.score > wrong.score + 0.05);
}

#[test]
fn a_drifting_loop_closes_and_its_map_has_single_walls() {
    let run = ring_run();
    let last = run.truth.len() - 1;
    let drift = distance(&run.front_end[last], &run.truth[last]);
    let turn = (run.front_end[last].theta - run.truth[last].theta).abs();
    assert!(
        drift > 1.0 && turn > 4f64.to_radians(),
        "{drift} m, {turn} rad"
    );
    let mapper = drive(test_config(), &run.keyframes, |_, _| {});
    let closures = mapper.loop_edges();
    let accepted = closures.iter().filter(|e| e.weight > 0.0).count();
    let end = mapper.poses()[last];
    let error = distance(&end, &run.truth[last]);
    let worst = (mapper.poses().iter().zip(&run.truth))
        .map(|(p, t)| distance(p, t))
        .fold(0.0, f64::max);
    println!(
        "front end off by {drift:.2} m, {:.1}° at the end; {} closures, {accepted} accepted; \
         end error {error:.3} m, worst {worst:.3} m",
        turn.to_degrees(),
        closures.len()
    );
    assert!(error < 0.1, "end keyframe {error} m off");
    // The correction maps the front end's last pose onto the optimised one.
    let corrected = mapper.corrected(&run.front_end[last]);
    assert!(distance(&corrected, &end) < 1e-9);
    // The first side's outer wall (y = −1) between boxes, mapped at the start and at the
    // end of the loop: one wall, not two.
    let render = GridConfig {
        resolution: 0.05,
        ..GridConfig::default()
    };
    let grid = mapper.render(&render, &Pose2::default()).unwrap();
    let (count, spread) = wall_spread(&grid, -1.0, (2.0, 3.9));
    println!("optimised: {count} occupied cells, farthest {spread:.3} m from the wall");
    assert!(
        count > 20 && spread <= 0.1 + 1e-9,
        "{count} cells, {spread} m"
    );
    // Along the front end's own poses the wall is doubled.
    let mut raw = LogOddsGrid::new(0.05, [-6.4, -6.4], 384, 384);
    for (k, pose) in run.keyframes.iter().zip(&run.front_end) {
        raw.integrate(pose, &k.beams, &render);
    }
    let (_, raw_spread) = wall_spread(&raw.occupancy(), -1.0, (2.0, 3.9));
    println!("front end: farthest {raw_spread:.3} m from the wall");
    assert!(raw_spread > 0.2);
}

#[test]
fn a_loop_drifting_beyond_the_usual_window_closes_in_the_wide_search() {
    let run = drifting_ring(0.3, 0.5, 1);
    let last = run.truth.len() - 1;
    let turn = (run.front_end[last].theta - run.truth[last].theta).abs();
    let drift = distance(&run.front_end[last], &run.truth[last]);
    let config = test_config();
    assert!(
        turn > config.max_angular_window && turn < config.wide_angular_window,
        "{} °",
        turn.to_degrees()
    );
    let end_error = |config: LoopClosureConfig| {
        let mapper = drive(config, &run.keyframes, |_, _| {});
        let accepted = (mapper.loop_edges().iter())
            .filter(|e| e.weight > 0.0)
            .count();
        (distance(&mapper.poses()[last], &run.truth[last]), accepted)
    };
    let (narrow, narrow_accepted) = end_error(LoopClosureConfig {
        wide_search_every: 0,
        ..test_config()
    });
    let (wide, wide_accepted) = end_error(test_config());
    println!(
        "front end off by {drift:.2} m, {:.1}° at the end; usual window only: end error \
         {narrow:.3} m, {narrow_accepted} closures; with the wide search: {wide:.3} m, \
         {wide_accepted} closures",
        turn.to_degrees()
    );
    assert!(
        narrow > drift / 2.0,
        "the usual window alone closed it: {narrow} m"
    );
    assert!(wide < drift / 10.0, "end keyframe {wide} m off");
}

#[test]
fn a_wrong_loop_closure_is_rejected() {
    let run = ring_run();
    let clean = drive(test_config(), &run.keyframes, |_, _| {});
    // On the ring's last side, 5 m before the start: no closure has come in yet.
    let before_closing = 80;
    let mut wrong = None;
    let torn = drive(test_config(), &run.keyframes, |k, mapper| {
        if k == before_closing {
            // Before the loop's true closures come in: the keyframe as if seen in a
            // similar corridor 2.5 m further along, turned by 6°, with the highest score
            // a match can have.
            let submap = 1;
            let anchor = mapper.submaps()[submap].anchor();
            let true_pose = run.truth[anchor].inverse().compose(&run.truth[k]);
            let closure = LoopClosure {
                keyframe: k,
                submap,
                pose: true_pose.compose(&Pose2::new(2.5, 0.0, 6f64.to_radians())),
                score: 1.0,
                lever: 3.0,
                curvature: None,
            };
            mapper.add_loop_closure(closure).unwrap();
            wrong = Some(closure);
        }
    });
    let wrong = wrong.expect("injected");
    let edge = (torn.loop_edges().iter())
        .find(|e| e.closure == wrong)
        .expect("in the graph");
    let moved = (clean.poses().iter().zip(torn.poses()))
        .map(|(a, b)| distance(a, b))
        .fold(0.0, f64::max);
    println!(
        "wrong closure: χ² {:.0}, weight {}; poses moved at most {moved:.4} m",
        edge.chi2, edge.weight
    );
    assert!(edge.weight < 0.05, "{edge:?}");
    assert!(moved < 0.1, "{moved} m");
}

#[test]
fn runs_are_identical_bit_for_bit_on_any_number_of_threads() {
    let run = ring_run();
    let on = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| drive(test_config(), &run.keyframes, |_, _| {}))
    };
    let (one, four) = (on(1), on(4));
    let bits = |m: &PoseGraphMapper| -> Vec<u64> {
        (m.poses().iter())
            .flat_map(|p| [p.x.to_bits(), p.y.to_bits(), p.theta.to_bits()])
            .collect()
    };
    assert_eq!(bits(&one), bits(&four));
    assert_eq!(one.loop_edges(), four.loop_edges());
    let render = GridConfig::default();
    assert_eq!(
        one.render(&render, &Pose2::default()),
        four.render(&render, &Pose2::default())
    );
}

#[test]
fn a_finished_submap_is_matched_from_the_keyframes_before_it() {
    let run = ring_run();
    // (keyframe, submap anchor, matched pose, weight in the last solve)
    let earlier = |mapper: &PoseGraphMapper| -> Vec<(usize, usize, Pose2, f64)> {
        (mapper.loop_edges().iter())
            .filter(|e| e.closure.keyframe < mapper.submaps()[e.closure.submap].anchor())
            .map(|e| {
                let c = e.closure;
                (
                    c.keyframe,
                    mapper.submaps()[c.submap].anchor(),
                    c.pose,
                    e.weight,
                )
            })
            .collect()
    };
    let off = LoopClosureConfig {
        earlier_keyframes: 0,
        ..test_config()
    };
    assert!(earlier(&drive(off, &run.keyframes, |_, _| {})).is_empty());
    let mapper = drive(test_config(), &run.keyframes, |_, _| {});
    let found = earlier(&mapper);
    // The first side's keyframes, found again in the submap the loop's end finished.
    let across = (found.iter())
        .filter(|(k, a, _, weight)| a - k > 60 && *weight > 0.0)
        .count();
    println!(
        "{} earlier keyframes matched, {across} across the loop",
        found.len()
    );
    assert!(across >= 3, "{found:?}");
    // Against the truth, each the solution uses is off by no more than the submap's own
    // distortion: its grid was built along the front end's poses, 2 % of each turn off
    // (up to 0.21 m at the far end of the submap finished after the last corner). A
    // match in a similar stretch of the ring is found now and then; the gate leaves it out.
    for &(k, anchor, pose, weight) in &found {
        let truth = run.truth[anchor].inverse().compose(&run.truth[k]);
        let off = distance(&pose, &truth);
        println!("keyframe {k} in {anchor}: {off:.3} m off, weight {weight}");
        assert!(
            off < 0.25 || weight == 0.0,
            "keyframe {k} in {anchor}: {pose:?} vs {truth:?}, weight {weight}"
        );
    }
}

#[test]
fn a_solve_with_nothing_new_settles_in_one_round() {
    let run = ring_run();
    let mut mapper = drive(test_config(), &run.keyframes, |_, _| {});
    let before = mapper.poses().to_vec();
    // The reweighting starts from the weights the last solve settled on: one round finds
    // them unchanged, and the gated solve after it moves nothing.
    let again = mapper.solve().unwrap();
    assert_eq!(again.rounds, 2, "{again:?}");
    let moved = (before.iter().zip(mapper.poses()))
        .map(|(a, b)| distance(a, b))
        .fold(0.0, f64::max);
    assert!(moved < 1e-6, "{moved} m");
}

#[test]
fn a_match_in_a_featureless_corridor_is_held_across_it_not_along_it() {
    // Two long parallel walls 2 m apart, nothing else: a scan can slide along them.
    let world: Vec<Segment> = vec![[-30.0, -1.0, 30.0, -1.0], [-30.0, 1.0, 30.0, 1.0]];
    let submap = submap_from(&world, &first_side(15), 1, 0.0);
    let truth = Pose2::new(3.2, 0.1, 0.03);
    let (_, points) = beams_and_points(&scan(&world, &truth, 0.01, 5));
    let window = SearchWindow {
        linear: 1.0,
        angular: 10f64.to_radians(),
    };
    let corridor = submap.match_scan(&points, &truth, &window, 0.0).unwrap();
    let c = corridor.curvature;
    println!(
        "corridor: along {:.3e}, across {:.3e}",
        c[(0, 0)],
        c[(1, 1)]
    );
    assert!(c[(0, 0)] < 0.1 * c[(1, 1)], "{c}");
    // In the ring's first corner both directions are held.
    let (submap, points, truth) = first_corner();
    let corner = submap.match_scan(&points, &truth, &window, 0.0).unwrap();
    let c = corner.curvature;
    println!("corner: x {:.3e}, y {:.3e}", c[(0, 0)], c[(1, 1)]);
    assert!(
        c[(0, 0)] > 0.1 * c[(1, 1)] && c[(1, 1)] > 0.1 * c[(0, 0)],
        "{c}"
    );
}

/// The real-time pose at each keyframe of `run` as the service publishes it: the front
/// end's pose moved by the correction of the solve that followed keyframe `k − delay`, in
/// that solve's gauge ([`local_gauge`] with `config.gauge_radius`).
fn published_poses(config: &LoopClosureConfig, run: &Run) -> Vec<Pose2> {
    let mut mapper = PoseGraphMapper::new(config.clone()).unwrap();
    let (mut corrections, mut published) = (Vec::new(), Vec::new());
    let mut gauge = Pose2::default();
    for (k, keyframe) in run.keyframes.iter().enumerate() {
        let report = mapper.add_keyframe(keyframe.clone()).unwrap();
        if report.solve_due {
            let solution = mapper.solve().unwrap();
            let radius = config.gauge_radius;
            gauge = local_gauge(&solution.poses, &published, radius).unwrap_or(gauge);
        }
        corrections.push(gauge.compose(&mapper.correction()));
        let in_force = k
            .checked_sub(config.delay_keyframes)
            .map_or_else(Pose2::default, |due| corrections[due]);
        published.push(in_force.compose(&run.front_end[k]));
    }
    published
}

#[test]
fn a_place_passed_again_is_published_where_it_was_published_before() {
    // Twice round the ring: the second lap passes every place of the first, which was
    // published with the drift of its time.
    let run = drifting_ring(0.05, 0.1, 2);
    let lap = loop_path(1, 0).len() - 1;
    // Over every place passed twice, how far the two published poses' relative motion is
    // from the true one (m): what a relation between the two visits measures.
    let revisit_error = |radius: f64| {
        let config = LoopClosureConfig {
            gauge_radius: radius,
            ..test_config()
        };
        let p = published_poses(&config, &run);
        let errors: Vec<f64> = (0..lap)
            .map(|k| {
                let (a, b) = (
                    p[k].inverse().compose(&p[k + lap]),
                    (run.truth[k].inverse()).compose(&run.truth[k + lap]),
                );
                distance(&a, &b)
            })
            .collect();
        errors.iter().sum::<f64>() / errors.len() as f64
    };
    let (gauged, fixed) = (revisit_error(3.0), revisit_error(0.0));
    println!("revisits: {gauged:.3} m in the gauge, {fixed:.3} m in the first keyframe's frame");
    assert!(gauged < 0.5 * fixed, "{gauged} m against {fixed} m");
}
