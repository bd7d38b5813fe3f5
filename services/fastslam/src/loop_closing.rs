//! Grid FastSLAM's loop-closing back-end on a thread of its own (docs/ALGORITHMS.md
//! §9.1). The filter's thread hands over each keyframe (its estimate, the covariance of
//! the motion since the previous keyframe, the scan's points and beams); the worker adds
//! it to a [`PoseGraphMapper`] — matching it against the finished submaps — solves when
//! one is due, and reports after every keyframe.
//!
//! The filter's estimate stays in its own frame (the front end's map); what the service
//! publishes is `correction ∘ estimate`, where the correction (map → front-end map, as
//! ROS's map → odom) comes from the solve that followed keyframe `k − delay` and is
//! applied at keyframe `k` ([`LoopClosureConfig::delay_keyframes`]). The filter waits for
//! that report only when the worker is later than the delay, so the published poses
//! depend on the data only. Each solve is moved into the map frame's gauge
//! ([`loop_closure::local_gauge`]): the keyframes near the robot land where the poses
//! published for them were. The correction, the smoothed trajectory and the rendered map
//! are all in that frame.
//!
//! When the input ends the worker solves a last time, the odometry constraints weighted
//! by their fit to the data ([`PoseGraphMapper::finish`]); the real-time
//! pose never sees that solve; the final trajectory comes from it. The final trajectory
//! and the map rendered after it are in the frame of the first keyframe (where its pose
//! was published), not in the gauge: a run's result starts where the run started.
//!
//! The smoothed trajectory has a pose for every scan: between two optimised keyframes,
//! the front end's path with their correction shared out along it by the motion model's
//! noise ([`loop_closure::place_scans`]).
//!
//! A checkpoint holds what the back-end was handed ([`BackEndState`]: every scan's stamp
//! and front-end pose, every keyframe); a resumed service hands it all to a fresh worker
//! again ([`LoopClosing::replay`]), which rebuilds the same submaps, graph and solves,
//! since they depend on the keyframes only.

use anyhow::bail;
use fastslam_estimation::Pose2;
use fastslam_estimation::graph::{Fit, Solution, SolveReport};
use fastslam_estimation::grid::{GridConfig, KeptBeam, OccupancyGrid};
use fastslam_estimation::loop_closure::{
    self, Keyframe, LoopClosureConfig, Odometry, OdometryFit, PoseGraphMapper,
};
use fastslam_estimation::motion::MotionModel;
use nalgebra::Matrix3;
use serde::{Deserialize, Serialize};
use std::collections::VecDeque;
use std::sync::mpsc::{Receiver, Sender, channel};
use std::thread::JoinHandle;

/// What the filter's thread asks of the worker.
#[derive(Debug)]
enum Request {
    /// Add this keyframe (and solve when due).
    Keyframe(Box<Keyframe>),
    /// Render the map from every keyframe at its current pose, moved by the gauge.
    Render(GridConfig, Pose2),
    /// The input ended: solve a last time.
    Finish,
}

/// What the worker sends back.
#[derive(Debug)]
enum Reply {
    /// Keyframe `index` was added; `solved` when a solve followed it.
    Added {
        index: usize,
        solved: Option<Solved>,
    },
    /// The map asked for.
    Rendered(Option<OccupancyGrid>),
    /// The last solve, when keyframes came after the previous one.
    Final(Option<Solved>),
}

/// A solve's result as the service needs it.
#[derive(Debug, Clone)]
struct Solved {
    /// Every keyframe's optimised pose so far.
    poses: Vec<Pose2>,
    /// Map → front-end map after the solve.
    correction: Pose2,
    chi2_per_dof: f64,
    iterations: usize,
    seconds: f64,
}

impl From<loop_closure::Solution> for Solved {
    fn from(s: loop_closure::Solution) -> Self {
        Self {
            poses: s.poses,
            correction: s.correction,
            chi2_per_dof: s.chi2_per_dof,
            iterations: s.iterations,
            seconds: s.seconds,
        }
    }
}

/// The worker thread, its channels, and the front end's record of every scan.
#[derive(Debug)]
pub struct LoopClosing {
    to_worker: Option<Sender<Request>>,
    from_worker: Receiver<Reply>,
    worker: Option<JoinHandle<()>>,
    delay: usize,
    /// Keyframe reports received and not yet due, in keyframe order.
    waiting: VecDeque<(usize, Option<Solved>)>,
    /// Keyframe reports received.
    reported: usize,
    /// Every keyframe handed over (the front end's pose at it, for the trajectory; all of
    /// it, for a checkpoint).
    keyframes: Vec<Keyframe>,
    /// Every scan since the first keyframe: stamp, the front end's pose, its keyframe.
    scans: Vec<(u64, Pose2, usize)>,
    /// The correction in force: map → front-end map.
    correction: Pose2,
    /// The pose published at each keyframe's scan, in keyframe order.
    published: Vec<Pose2>,
    /// [`LoopClosureConfig::gauge_radius`].
    gauge_radius: f64,
    /// The map frame's gauge of the solution in force ([`loop_closure::local_gauge`]).
    gauge: Pose2,
    /// The newest applied solve not yet published.
    unpublished: Option<Solved>,
    /// The newest applied solve as the graph solved it: in the frame of the first
    /// keyframe, which the graph's prior holds where its pose was published.
    in_force: Option<Solved>,
    /// [`LoopClosing::finish`] was called: the last solve is made.
    finished: bool,
    solves: u32,
    /// The front end's motion model: how a correction is shared out between keyframes.
    motion: MotionModel,
}

impl LoopClosing {
    /// Starts the worker with `config`; `motion` is the front end's motion model.
    ///
    /// # Errors
    /// When the configuration is invalid or the thread cannot be started.
    pub fn start(config: LoopClosureConfig, motion: MotionModel) -> anyhow::Result<Self> {
        let (delay, gauge_radius) = (config.delay_keyframes, config.gauge_radius);
        let mut mapper = PoseGraphMapper::new(config)?;
        let (to_worker, inbox) = channel::<Request>();
        let (outbox, from_worker) = channel::<Reply>();
        let worker = std::thread::Builder::new()
            .name("loop-closing".into())
            .spawn(move || {
                let (mut index, mut refused) = (0, false);
                for request in inbox {
                    let reply = match request {
                        Request::Keyframe(keyframe) => {
                            let solved = if refused {
                                None
                            } else {
                                let added = add(&mut mapper, *keyframe);
                                refused = added.is_err();
                                added.ok().flatten()
                            };
                            index += 1;
                            Reply::Added {
                                index: index - 1,
                                solved,
                            }
                        }
                        Request::Render(grid, gauge) => {
                            Reply::Rendered(mapper.render(&grid, &gauge))
                        }
                        Request::Finish => {
                            Reply::Final(if refused { None } else { finish(&mut mapper) })
                        }
                    };
                    if outbox.send(reply).is_err() {
                        return;
                    }
                }
            })?;
        Ok(Self {
            to_worker: Some(to_worker),
            from_worker,
            worker: Some(worker),
            delay,
            waiting: VecDeque::new(),
            reported: 0,
            keyframes: Vec::new(),
            scans: Vec::new(),
            correction: Pose2::default(),
            published: Vec::new(),
            gauge_radius,
            gauge: Pose2::default(),
            unpublished: None,
            in_force: None,
            finished: false,
            solves: 0,
            motion,
        })
    }

    /// Takes a scan's front-end pose `estimate` and, when the scan was a keyframe, the
    /// keyframe (with the odometry's account of the stretch before it); returns the pose
    /// in the map frame (`correction ∘ estimate`) with the correction of keyframe
    /// `k − delay` applied at keyframe `k`.
    pub fn scan(&mut self, stamp_ns: u64, estimate: Pose2, keyframe: Option<Keyframe>) -> Pose2 {
        let is_keyframe = keyframe.is_some();
        if let Some(keyframe) = keyframe {
            let index = self.keyframes.len();
            self.keyframes.push(keyframe.clone());
            self.send(Request::Keyframe(Box::new(keyframe)));
            if let Some(due) = index.checked_sub(self.delay) {
                self.apply_until(due);
            }
        }
        if let Some(k) = self.keyframes.len().checked_sub(1) {
            self.scans.push((stamp_ns, estimate, k));
        }
        let published = self.correction.compose(&estimate);
        if is_keyframe {
            self.published.push(published);
        }
        published
    }

    /// The correction in force (map → front-end map); the identity before the first solve.
    pub fn correction(&self) -> Pose2 {
        self.correction
    }

    /// The map rendered from every keyframe at its current pose; waits for the worker to
    /// get through what it was given (`None` before the first keyframe or when the worker
    /// is gone).
    pub fn render(&mut self, grid: &GridConfig) -> Option<OccupancyGrid> {
        self.send(Request::Render(grid.clone(), self.gauge));
        loop {
            match self.receive()? {
                Reply::Rendered(grid) => return grid,
                Reply::Added { index, solved } => self.waiting.push_back((index, solved)),
                Reply::Final(_) => return None,
            }
        }
    }

    /// The newest applied solve not published yet, as a smoothed trajectory (every scan
    /// so far).
    pub fn latest(&mut self) -> Option<Solution> {
        let solved = self.unpublished.take()?;
        Some(self.trajectory(&solved))
    }

    /// Asks the worker for its last solve and waits for it; every report not applied yet
    /// is applied. The final trajectory (every scan), or `None` without a solve. The final
    /// trajectory, the correction and the map rendered from then on are in the frame of
    /// the first keyframe, where it was published, not in the map frame's gauge: a run's
    /// result starts where the run started. `None` when called again.
    pub fn finish(&mut self) -> Option<Solution> {
        if std::mem::replace(&mut self.finished, true) {
            return None;
        }
        self.send(Request::Finish);
        let mut last = None;
        loop {
            match self.receive() {
                Some(Reply::Added { index, solved }) => self.waiting.push_back((index, solved)),
                Some(Reply::Rendered(_)) => {}
                Some(Reply::Final(solved)) => {
                    last = solved;
                    break;
                }
                None => {
                    tracing::error!(
                        "the loop-closing back-end stopped before its last solve: the final \
                         trajectory is the last solve it made"
                    );
                    break;
                }
            }
        }
        self.apply_until(usize::MAX);
        if let Some(solved) = last {
            self.adopt(solved);
        }
        let solved = self.in_force.clone()?;
        self.gauge = Pose2::default();
        self.correction = solved.correction;
        self.unpublished = None;
        Some(self.trajectory(&solved))
    }

    /// What the back-end was handed so far, for a checkpoint.
    pub fn state(&self) -> BackEndState {
        BackEndState {
            scans: self.scans.clone(),
            keyframes: self.keyframes.iter().map(KeyframeState::from).collect(),
            unpublished: self.unpublished.is_some(),
        }
    }

    /// Hands this fresh back-end what `state` says the one of the checkpointed run was
    /// handed, scan by scan, as that run did: the same keyframes, solves and correction
    /// follow, and a solve that run had published is not published again.
    ///
    /// # Errors
    /// When the scans refer to a keyframe out of order or one the state does not hold.
    pub fn replay(&mut self, state: &BackEndState) -> anyhow::Result<()> {
        let mut next = 0;
        for &(stamp_ns, estimate, k) in &state.scans {
            let keyframe = if k == next {
                let Some(keyframe) = state.keyframes.get(k) else {
                    bail!("the loop-closure state's scans name keyframe {k} it does not hold");
                };
                Some(Keyframe::from(keyframe))
            } else if k + 1 == next {
                None
            } else {
                bail!("the loop-closure state's scans name keyframe {k} after {next}");
            };
            next += usize::from(keyframe.is_some());
            self.scan(stamp_ns, estimate, keyframe);
        }
        if next != state.keyframes.len() {
            bail!(
                "the loop-closure state holds {} keyframes, its scans name {next}",
                state.keyframes.len()
            );
        }
        if !state.unpublished {
            self.unpublished = None;
        }
        Ok(())
    }

    /// Hands `request` to the worker; a worker that is gone is reported once.
    fn send(&mut self, request: Request) {
        if let Some(to) = &self.to_worker
            && to.send(request).is_err()
        {
            tracing::error!("the loop-closing back-end is gone: loop closure stops");
            self.to_worker = None;
        }
    }

    /// The next reply, waiting for it; `None` when the worker is gone.
    fn receive(&mut self) -> Option<Reply> {
        let reply = self.from_worker.recv().ok();
        if let Some(Reply::Added { .. }) = reply {
            self.reported += 1;
        }
        reply
    }

    /// Applies, in order, every keyframe report up to keyframe `due`, waiting for the
    /// worker until it has reported `due` (or all it was given, at the end).
    fn apply_until(&mut self, due: usize) {
        let wanted = due.saturating_add(1).min(self.keyframes.len());
        while self.reported < wanted {
            match self.receive() {
                Some(Reply::Added { index, solved }) => self.waiting.push_back((index, solved)),
                Some(_) => {}
                None => break,
            }
        }
        while self.waiting.front().is_some_and(|(index, _)| *index <= due) {
            if let Some((_, Some(solved))) = self.waiting.pop_front() {
                self.adopt(solved);
            }
        }
    }

    /// Makes `solved` the solution in force, moved into the map frame's gauge.
    fn adopt(&mut self, mut solved: Solved) {
        self.solves += 1;
        self.in_force = Some(solved.clone());
        if let Some(gauge) =
            loop_closure::local_gauge(&solved.poses, &self.published, self.gauge_radius)
        {
            self.gauge = gauge;
        }
        for pose in &mut solved.poses {
            *pose = self.gauge.compose(pose);
        }
        solved.correction = self.gauge.compose(&solved.correction);
        self.correction = solved.correction;
        tracing::debug!(
            solve = self.solves,
            keyframes = solved.poses.len(),
            chi2_per_dof = solved.chi2_per_dof,
            iterations = solved.iterations,
            seconds = solved.seconds,
            "loop-closure solution applied"
        );
        self.unpublished = Some(solved);
    }

    /// Every scan's pose under `solved`: between two optimised keyframes, the share of
    /// their correction the motion model gives it ([`loop_closure::place_scans`]); after
    /// the newest, its keyframe's optimised pose moved by the front end since; the
    /// correction for keyframes the solve has not seen.
    fn trajectory(&self, solved: &Solved) -> Solution {
        let scans: Vec<(Pose2, usize)> = self.scans.iter().map(|&(_, pose, k)| (pose, k)).collect();
        let front_end: Vec<Pose2> = self.keyframes.iter().map(|k| k.pose).collect();
        // Where the odometry alone ended each stretch; without an odometry account, where
        // the front end put the keyframe.
        let predicted: Vec<Pose2> = (self.keyframes.iter())
            .map(|k| k.odometry.map_or(k.pose, |o| o.predicted))
            .collect();
        let placed = loop_closure::place_scans(
            &scans,
            &front_end,
            &predicted,
            &solved.poses,
            &solved.correction,
            |delta| self.motion.path_variances(delta),
        );
        let poses = (self.scans.iter())
            .zip(placed)
            .map(|(&(stamp, _, _), pose)| (stamp, pose))
            .collect();
        Solution {
            poses,
            landmarks: Vec::new(),
            // The loop closures enter χ² with their final weights: it is already robust;
            // the pose graph has no sightings to count as outliers.
            fit: Fit {
                chi2_per_dof: solved.chi2_per_dof,
                robust_per_dof: solved.chi2_per_dof,
                outlier_share: 0.0,
            },
            report: SolveReport {
                iterations: solved.iterations,
                initial_cost: f64::NAN,
                final_cost: f64::NAN,
                converged: true,
                seconds: solved.seconds,
            },
            solves: self.solves,
            whole: true,
            fused: 0,
        }
    }
}

impl Drop for LoopClosing {
    fn drop(&mut self) {
        self.to_worker = None;
        if let Some(worker) = self.worker.take()
            && worker.join().is_err()
        {
            tracing::error!("the loop-closing back-end panicked");
        }
    }
}

/// What the loop-closing back-end was handed, as plain data (a checkpoint's part).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BackEndState {
    /// Every scan since the first keyframe: stamp (ns), the front end's pose, its
    /// keyframe.
    pub scans: Vec<(u64, Pose2, usize)>,
    /// Every keyframe handed over, in order.
    pub keyframes: Vec<KeyframeState>,
    /// The newest solve applied had not been published yet.
    pub unpublished: bool,
}

/// A [`Keyframe`] as plain data.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct KeyframeState {
    /// Time of the scan (ns).
    pub stamp_ns: u64,
    /// The front end's estimate of the base pose at the scan.
    pub pose: Pose2,
    /// The covariance of the motion since the previous keyframe, row-major.
    pub covariance: [f64; 9],
    /// The scan's end points, base frame (m).
    pub points: Vec<[f64; 2]>,
    /// The scan's beams: angle (rad), length (m), ended on an obstacle.
    pub beams: Vec<(f32, f32, bool)>,
    /// The sensor's pose in the base frame.
    pub sensor: Pose2,
    /// The odometry's account of the motion from the previous keyframe: the front end's
    /// pose of the scan before it was matched, and the motion model's covariance,
    /// row-major.
    pub odometry: Option<(Pose2, [f64; 9])>,
}

impl From<&Keyframe> for KeyframeState {
    fn from(k: &Keyframe) -> Self {
        Self {
            stamp_ns: k.stamp_ns,
            pose: k.pose,
            covariance: std::array::from_fn(|i| k.covariance[(i / 3, i % 3)]),
            points: k.points.clone(),
            beams: (k.beams.iter())
                .map(|b| (b.angle, b.length, b.hit))
                .collect(),
            sensor: k.sensor,
            odometry: (k.odometry).map(|o| {
                let covariance = std::array::from_fn(|i| o.covariance[(i / 3, i % 3)]);
                (o.predicted, covariance)
            }),
        }
    }
}

impl From<&KeyframeState> for Keyframe {
    fn from(k: &KeyframeState) -> Self {
        Self {
            stamp_ns: k.stamp_ns,
            pose: k.pose,
            covariance: Matrix3::from_row_slice(&k.covariance),
            points: k.points.clone(),
            beams: (k.beams.iter())
                .map(|&(angle, length, hit)| KeptBeam { angle, length, hit })
                .collect(),
            sensor: k.sensor,
            odometry: k.odometry.map(|(predicted, c)| Odometry {
                predicted,
                covariance: Matrix3::from_row_slice(&c),
            }),
        }
    }
}

/// Adds `keyframe` and solves when one is due. A keyframe the back-end refuses (a value
/// not finite, a stamp out of order) ends loop closure for the run: the keyframes after
/// it would no longer line up with the front end's.
fn add(mapper: &mut PoseGraphMapper, keyframe: Keyframe) -> Result<Option<Solved>, ()> {
    let index = mapper.keyframes();
    let stamp_s = keyframe.stamp_ns as f64 * 1e-9;
    match mapper.add_keyframe(keyframe) {
        Ok(report) => {
            if report.wide_found > 0 {
                tracing::info!(
                    keyframe = report.index,
                    stamp_s,
                    submaps = report.wide,
                    closures = report.wide_found,
                    "wide loop-closure search matched: no long loop had closed over the last \
                     keyframes, so the submaps beyond the usual window were searched in the \
                     wide one"
                );
            } else if report.wide > 0 {
                tracing::debug!(
                    keyframe = report.index,
                    stamp_s,
                    submaps = report.wide,
                    "wide loop-closure search found nothing"
                );
            }
            for c in &report.closures {
                tracing::debug!(
                    keyframe = c.keyframe,
                    at = report.index,
                    stamp_s,
                    submap = c.submap,
                    score = c.score,
                    "loop closure found"
                );
            }
            Ok(report.solve_due.then(|| solve(mapper)).flatten())
        }
        Err(e) => {
            tracing::error!(
                "keyframe {index} refused by the loop-closure back-end, loop closure stops \
                 (the last solution stays in force): {e}"
            );
            Err(())
        }
    }
}

/// The mapper's last solve ([`PoseGraphMapper::finish`]), logged; its newest solution.
fn finish(mapper: &mut PoseGraphMapper) -> Option<Solved> {
    let mut finished = mapper.finish();
    match finished.odometry {
        OdometryFit::Off => {}
        OdometryFit::Unfitted => tracing::info!(
            "last solve: the odometry constraints keep the model's weight (too few of them \
             or of loop closures, or no variance components, to fit it)"
        ),
        OdometryFit::Weighted(fit) => tracing::info!(
            weight = fit.weight,
            odometry_factor = fit.odometry.scale,
            odometry_redundancy = fit.odometry.redundancy,
            rest_factor = fit.rest.scale,
            rest_redundancy = fit.rest.redundancy,
            "last solve: the odometry constraints weighted by their variance factor against \
             the front end's steps and the loop closures"
        ),
    }
    if let Some(e) = &finished.failed {
        tracing::warn!("loop-closure solve at the end failed, the solution before it stands: {e}");
    }
    finished.solutions.pop().map(Solved::from)
}

/// One solve of the mapper's graph; a failure is logged.
fn solve(mapper: &mut PoseGraphMapper) -> Option<Solved> {
    match mapper.solve() {
        Ok(solution) => Some(solution.into()),
        Err(e) => {
            tracing::warn!("loop-closure solve failed, the previous solution stands: {e}");
            None
        }
    }
}
