//! One update of [`FastSlam`]: its entry points, then the stages in the order they run:
//! FastSLAM 2.0's proposal, the optional refiner, association, weighing, the estimate (before
//! resampling), the resampling draw, the map updates and the resampled copies.

use super::*;

impl FastSlam {
    /// Steps 3–6 for one scan from the configured sensor, without pose refinement
    /// (FastSLAM 1.0, or 2.0 when configured); see [`update_with`](Self::update_with).
    ///
    /// # Errors
    /// As [`update_with`](Self::update_with).
    pub fn update(&mut self, observations: &[Observation]) -> Result<StepReport> {
        let sensor = self.config.sensor.clone();
        self.update_with(observations, &sensor, None)
    }

    /// One scan taken by `sensor` (a scan may carry its own noise, range and field of
    /// view): FastSLAM 2.0's proposal when configured, the optional refiner,
    /// association and weighing (3), normalisation (5), resampling (6), map updates and
    /// negative evidence (4).
    ///
    /// A particle's weight increment is the scan's likelihood at its final pose, unless
    /// the proposal or the refiner gave it another ([`WeightBasis`]).
    ///
    /// Observations that are not finite, have a range the sensor cannot report
    /// ([`Sensor::can_report`]), or lack an id under known association are skipped and
    /// counted in [`StepReport::rejected`].
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] for a bad `sensor` or a refiner on a filter
    /// [`without_motion_prior`](Self::without_motion_prior), the refiner's error, or
    /// [`Error::DegenerateWeights`] when no particle keeps a usable weight. On these errors
    /// weights and maps are unchanged (the proposal or a refiner may already have moved
    /// poses).
    ///
    /// # Performance
    /// O(N · n · (log M + k)) for n observations and k landmarks per search window:
    /// independent of the map size M but for the logarithm. Resampling copies no map.
    pub fn update_with(
        &mut self,
        observations: &[Observation],
        sensor: &Sensor,
        refiner: Option<&mut dyn PoseRefiner>,
    ) -> Result<StepReport> {
        self.update_publishing(observations, sensor, refiner, |_| {})
    }

    /// [`update_with`](Self::update_with), handing the step's pose estimate to `publish`
    /// the moment it is known: after weighing, before resampling and the map updates
    /// (see the module documentation for what it is). A caller can send the pose while
    /// the maps are still being written, which takes about half of a step.
    ///
    /// `publish` is called once if the step succeeds, never if it fails.
    ///
    /// # Errors
    /// As [`update_with`](Self::update_with).
    pub fn update_publishing(
        &mut self,
        observations: &[Observation],
        sensor: &Sensor,
        refiner: Option<&mut dyn PoseRefiner>,
        publish: impl FnOnce(&PoseEstimate),
    ) -> Result<StepReport> {
        sensor.validate()?;
        if refiner.is_some() && !self.motion_prior {
            return Err(Error::InvalidParameter {
                name: "optimizer",
                reason: "a pose refiner needs the motion prior".into(),
            });
        }
        let mut accepted = std::mem::take(&mut self.scratch.accepted);
        accepted.clear();
        let association = self.config.association.clone();
        accepted.extend(observations.iter().copied().filter(|obs| {
            obs.validate().is_ok() && sensor.can_report(obs) && association.accepts(obs)
        }));
        let scan = Scan::new(&accepted, sensor, &association, self.step + 1);
        let result = self.run_stages(&scan, refiner, publish);
        self.scratch.accepted = accepted;
        let mut report = result?;
        report.rejected = observations.len() - self.scratch.accepted.len();
        Ok(report)
    }

    /// The stages of one update, in the order they run.
    pub(super) fn run_stages(
        &mut self,
        scan: &Scan<'_>,
        mut refiner: Option<&mut dyn PoseRefiner>,
        publish: impl FnOnce(&PoseEstimate),
    ) -> Result<StepReport> {
        let parallel = parallel::pays(self.particles.len(), scan.observations().len() + 1);
        self.start_step();
        // The noise check, at the best particle's prior before anything moves it.
        let innovations = Innovations::of(
            scan,
            &self.particles[self.best].map,
            &self.check_prior,
            &mut self.scratch.check,
            &mut self.noise,
        );
        // FastSLAM 2.0: draw each pose from the proposal that uses this scan.
        if self.config.proposal == Proposal::FastSlam2 {
            self.propose_fastslam2(scan, parallel);
        }
        // Optimise (optional): move or draw the poses.
        if let Some(refiner) = refiner.as_deref_mut() {
            self.refine(scan, refiner)?;
        }
        // Associate at the final poses; deferred particles the scan uses but nothing
        // drew are drawn from their prior now.
        self.associate(scan, parallel, None);
        if self.deferred {
            self.draw_from_priors(scan, parallel);
        }
        // Weigh and normalise (log-sum-exp); N_eff.
        let mut weights = self.weigh()?;
        let neff = weights.ess();
        let best = weights.argmax();
        // The estimate: the weighted cloud before resampling, handed out now.
        publish(&self.mixture(&weights));
        // Draw the resampling ancestors when N_eff < neff_ratio · N.
        let resampled = self.draw_ancestors(&mut weights, scan.step())?;
        // Update the maps and make the resampled copies: copies first when a
        // refiner moves them (resample-move), so each updates its map from its own pose.
        let rejuvenating = resampled.is_some() && refiner.is_some();
        if let (Some(r), Some(refiner), true) = (&resampled, refiner, rejuvenating) {
            self.replace_by_copies(r);
            self.rejuvenate(scan, r, refiner, parallel)?;
            self.update_maps(scan, parallel);
        } else {
            self.update_maps(scan, parallel);
            match &resampled {
                Some(r) => self.replace_by_copies(r),
                None => {
                    for (p, &lw) in self.particles.iter_mut().zip(weights.log_weights()) {
                        p.log_weight = lw;
                    }
                }
            }
        }
        // Every copy of a resampled cloud weighs the same: the best is the first copy of
        // the particle that weighed most.
        self.best = resampled.as_ref().map_or(best, |r| {
            r.ancestors
                .iter()
                .position(|&a| a == best)
                .unwrap_or_else(|| weights.argmax())
        });
        self.check_prior = MotionPrior::settled(
            self.particles[self.best].pose,
            &self.config.prior_floor.covariance(),
        );
        std::mem::swap(&mut self.weights, &mut weights);
        self.scratch.spare_weights = Some(weights);
        self.step = scan.step();
        self.adapt_noise();
        let steps = &self.scratch.particles;
        let total =
            |f: fn(&MapChanges) -> usize| -> usize { steps.iter().map(|s| f(&s.changes)).sum() };
        Ok(StepReport {
            neff,
            resampled: resampled.is_some(),
            distinct: resampled
                .as_ref()
                .map_or(self.particles.len(), |r| r.distinct()),
            matched: total(|c| c.matched),
            new_landmarks: total(|c| c.created),
            ignored: total(|c| c.ignored),
            removed: total(|c| c.removed),
            rejected: 0,
            innovations,
        })
    }

    /// Resets the per-particle bookkeeping of a step: every weight from the final pose,
    /// every deferred particle open, the others points.
    fn start_step(&mut self) {
        let n = self.particles.len();
        let Scratch {
            basis, components, ..
        } = &mut self.scratch;
        basis.clear();
        basis.resize(n, WeightBasis::FinalPosition);
        components.clear();
        let start = if self.deferred {
            Component::Open
        } else {
            Component::Point
        };
        components.resize(n, start);
    }

    /// FastSLAM 2.0's draw for every particle with a matched landmark.
    fn propose_fastslam2(&mut self, scan: &Scan<'_>, parallel: bool) {
        let streams = Streams::new(self.config.seed, &[scan.step()]);
        let Scratch {
            basis,
            drawn,
            components,
            ..
        } = &mut self.scratch;
        parallel::map_into(parallel, &self.particles, drawn, |i, p| {
            let mut rng = streams.stream(&[i as u64, PURPOSE_PROPOSAL]);
            proposal::fastslam2(scan, p, &mut rng)
        });
        for (((p, b), c), d) in self
            .particles
            .iter_mut()
            .zip(basis.iter_mut())
            .zip(components.iter_mut())
            .zip(drawn.iter())
        {
            if let Some(d) = d {
                p.pose = d.pose;
                *b = WeightBasis::Given(d.log_likelihood);
                *c = Component::Drawn {
                    mean: d.mean,
                    covariance: d.covariance,
                };
            }
        }
    }

    /// the refiner; a particle it moved or drew is a point from now on.
    fn refine(&mut self, scan: &Scan<'_>, refiner: &mut dyn PoseRefiner) -> Result<()> {
        let Scratch {
            predicted,
            basis,
            components,
            ..
        } = &mut self.scratch;
        // The poses before the refiner, to see which it changed (reusing the prediction's buffer).
        predicted.clear();
        predicted.extend(self.particles.iter().map(|p| (p.pose, p.prior)));
        let before: Vec<WeightBasis> = basis.clone();
        refiner.refine(scan, &mut self.particles, basis)?;
        for (((p, (pose, _)), c), (b, old)) in self
            .particles
            .iter()
            .zip(predicted.iter())
            .zip(components.iter_mut())
            .zip(basis.iter().zip(before))
        {
            if p.pose != *pose || *b != old {
                *c = Component::Point;
            }
        }
        Ok(())
    }

    /// each particle's association at its current pose, into the step buffers;
    /// with `only`, just the particles it marks.
    fn associate(&mut self, scan: &Scan<'_>, parallel: bool, only: Option<&[bool]>) {
        let steps = &mut self.scratch.particles;
        steps.resize_with(self.particles.len(), ParticleStep::default);
        // FastSLAM 2.0 weighs by its proposal's marginal, which a sampled association
        // would not enter: it associates as `greedy`.
        if self.config.association.assignment == Assignment::Sampled
            && self.config.proposal != Proposal::FastSlam2
        {
            let streams = Streams::new(self.config.seed, &[scan.step()]);
            for (i, s) in steps.iter_mut().enumerate() {
                s.association.sampler = Some(streams.stream(&[i as u64, PURPOSE_ASSOCIATION]));
            }
        }
        match only {
            None => parallel::zip_mut(parallel, &mut self.particles, steps, |p, s| {
                scan.associate_into(&p.map, &p.pose, &mut s.association);
            }),
            Some(only) => {
                for ((p, s), _) in self
                    .particles
                    .iter()
                    .zip(steps.iter_mut())
                    .zip(only)
                    .filter(|(_, o)| **o)
                {
                    scan.associate_into(&p.map, &p.pose, &mut s.association);
                }
            }
        }
    }

    /// Deferred sampling: an open particle whose association updates or starts
    /// a landmark is drawn from its motion prior (its weight is then the likelihood at the
    /// drawn pose, the bootstrap filter's) and associated again there.
    fn draw_from_priors(&mut self, scan: &Scan<'_>, parallel: bool) {
        let streams = Streams::new(self.config.seed, &[scan.step()]);
        let Scratch {
            particles: steps,
            components,
            moved,
            ..
        } = &mut self.scratch;
        moved.clear();
        moved.extend(components.iter().zip(steps.iter()).map(|(c, s)| {
            *c == Component::Open
                && s.association
                    .decisions
                    .iter()
                    .any(|d| !matches!(d, Decision::Ignore))
        }));
        if !moved.iter().any(|&m| m) {
            return;
        }
        for (i, ((p, c), &draw)) in self
            .particles
            .iter_mut()
            .zip(components.iter_mut())
            .zip(moved.iter())
            .enumerate()
        {
            if !draw {
                continue;
            }
            let mut rng = streams.stream(&[i as u64, PURPOSE_PRIOR_DRAW]);
            if let Some(prior) = Gaussian::new(Vector3::zeros(), p.prior.covariance) {
                let d = prior.sample(&mut rng);
                let x = &p.prior.mean;
                p.pose = Pose2::new(x.x + d[0], x.y + d[1], x.theta + d[2]);
            }
            *c = Component::Point;
        }
        let only = std::mem::take(&mut self.scratch.moved);
        self.associate(scan, parallel, Some(&only));
        self.scratch.moved = only;
    }

    /// the new weights, `log wᵢ + increment`, normalised.
    fn weigh(&mut self) -> Result<Weights> {
        let Scratch {
            basis,
            particles: steps,
            log_weights,
            spare_weights,
            ..
        } = &mut self.scratch;
        log_weights.clear();
        log_weights.extend(
            self.particles
                .iter()
                .zip(steps.iter())
                .zip(basis.iter())
                .map(|((p, s), b)| p.log_weight + b.increment(s.association.log_likelihood)),
        );
        let mut weights = spare_weights.take().unwrap_or_else(|| self.weights.clone());
        weights.renormalise(log_weights)?;
        Ok(weights)
    }

    /// the mixture of the particles' components under `weights`.
    fn mixture(&self, weights: &Weights) -> PoseEstimate {
        let zero = Matrix3::zeros();
        let components =
            self.particles
                .iter()
                .zip(&self.scratch.components)
                .map(|(p, c)| match *c {
                    Component::Point => (p.pose, zero),
                    Component::Drawn { mean, covariance } => (mean, covariance),
                    Component::Open => (p.prior.mean, p.prior.covariance),
                });
        PoseEstimate::from_mixture(components, weights.as_slice())
    }

    /// the resampling ancestors when due, with `weights` replaced by the
    /// copies' weights.
    fn draw_ancestors(&self, weights: &mut Weights, step: u64) -> Result<Option<Resampled>> {
        if !self.config.resampling.due(weights) {
            return Ok(None);
        }
        let mut rng = stream(self.config.seed, &[step, 0, PURPOSE_RESAMPLE]);
        let resampled = self.config.resampling.draw(weights, &mut rng);
        weights.renormalise(&resampled.log_weights)?;
        Ok(Some(resampled))
    }

    /// Resample-move, after [`replace_by_copies`](Self::replace_by_copies): the refiner
    /// moves the copies; the moved ones become points and are associated again.
    fn rejuvenate(
        &mut self,
        scan: &Scan<'_>,
        resampled: &Resampled,
        refiner: &mut dyn PoseRefiner,
        parallel: bool,
    ) -> Result<()> {
        let Scratch {
            components,
            particles: steps,
            moved,
            ..
        } = &mut self.scratch;
        // The copies' components and associations are their ancestors'.
        let (ancestor_components, ancestor_steps) = (components.clone(), std::mem::take(steps));
        components.clear();
        components.extend(resampled.ancestors.iter().map(|&a| ancestor_components[a]));
        steps.extend(
            resampled
                .ancestors
                .iter()
                .map(|&a| ancestor_steps[a].clone()),
        );
        moved.clear();
        moved.resize(resampled.ancestors.len(), false);
        refiner.rejuvenate(scan, &mut self.particles, &resampled.ancestors, moved)?;
        for (c, &m) in components.iter_mut().zip(moved.iter()) {
            if m {
                *c = Component::Point;
            }
        }
        let only = std::mem::take(&mut self.scratch.moved);
        self.associate(scan, parallel, Some(&only));
        self.scratch.moved = only;
        Ok(())
    }

    /// EKF updates, new landmarks and negative evidence from each particle's
    /// association; the motion prior of every particle whose pose is now settled starts
    /// from it (an open one keeps accumulating).
    fn update_maps(&mut self, scan: &Scan<'_>, parallel: bool) {
        let evidence = &self.config.negative_evidence_in_effect();
        let floor = self.config.prior_floor.covariance();
        let map_fixed = self.map_fixed;
        let Scratch {
            particles: steps,
            components,
            ..
        } = &mut self.scratch;
        for (s, c) in steps.iter_mut().zip(components.iter()) {
            s.open = *c == Component::Open;
        }
        parallel::zip_mut(parallel, &mut self.particles, steps, |p, s| {
            if !s.open {
                p.prior = MotionPrior::settled(p.pose, &floor);
            }
            s.changes = if map_fixed {
                MapChanges::default()
            } else {
                p.apply(scan, &s.association, evidence)
            };
        });
    }

    /// Replaces the particles by the copies `resampled` draws (O(1) each: maps are
    /// shared).
    fn replace_by_copies(&mut self, resampled: &Resampled) {
        let before = &mut self.scratch.spare_particles;
        std::mem::swap(before, &mut self.particles);
        self.particles
            .extend(resampled.ancestors.iter().zip(&resampled.log_weights).map(
                |(&a, &log_weight)| Particle {
                    log_weight,
                    ..before[a].clone()
                },
            ));
        // Dropping the old particles now releases their references to the maps, so the
        // next writes copy only what the new particles really share.
        before.clear();
    }
}
