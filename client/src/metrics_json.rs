//! The shape of `metrics.json`: [`Metrics`] as it is written and read back, leaving out
//! what the run did not measure — the truth-based errors of each trajectory,
//! `consistency` and `map` in a run without ground truth, `reference` and `smoothed`
//! when there is none, and `relations` without a relations file. A run with ground
//! truth writes the same keys, in the same order, as [`Metrics`]' fields, then the
//! run's [`Warnings`] (derived from the rest, so not read back).

use crate::metrics::{
    Consistency, Cost, FilterHealth, InputAccount, MapMetrics, Metrics, SmoothedMetrics,
};
use crate::reference::ReferenceMetrics;
use crate::relations::RelationErrors;
use crate::rpe::Rpe;
use crate::scoring::{Alignment, ScoreAt, TrajectoryMetrics};
use crate::warnings::Warnings;
use serde::{Deserialize, Serialize};

/// `metrics.json` as written.
#[derive(Debug, Clone, Serialize, Deserialize)]
struct MetricsFile {
    complete: bool,
    /// A file without the key is one of a run with ground truth.
    #[serde(default = "with_truth")]
    ground_truth: bool,
    alignment: Alignment,
    scored_at: ScoreAt,
    estimate: TrajectoryFile,
    dead_reckoning: TrajectoryFile,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    reference: Option<ReferenceMetrics>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    smoothed: Option<SmoothedFile>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    consistency: Option<Consistency>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    map: Option<MapMetrics>,
    filter: FilterHealth,
    #[serde(default)]
    inputs: InputAccount,
    cost: Cost,
    /// Written for the reader and `--expect`; derived from the rest when read back.
    #[serde(default)]
    warnings: Warnings,
}

/// The value of `ground_truth` in a file without the key.
fn with_truth() -> bool {
    true
}

/// A trajectory's scores as written: the truth-based errors only when measured (a
/// number not measured in a run with truth is `null`, one not measured for want of truth
/// is absent). Written out field by field, not flattened, so every number is read
/// straight from the text (a flattened one goes through serde's buffer, which may not
/// give back the last bit of a float).
#[derive(Debug, Clone, Serialize, Deserialize)]
struct TrajectoryFile {
    poses: usize,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[serde(deserialize_with = "present")]
    ate_rmse_m: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[serde(deserialize_with = "present")]
    max_error_m: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[serde(deserialize_with = "present")]
    final_error_m: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[serde(deserialize_with = "present")]
    heading_rmse_rad: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    rpe: Option<Vec<Rpe>>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    relations: Option<RelationErrors>,
}

/// The smoothing back-end's scores as written: its trajectory's, then its fit and map.
#[derive(Debug, Clone, Serialize, Deserialize)]
struct SmoothedFile {
    poses: usize,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[serde(deserialize_with = "present")]
    ate_rmse_m: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[serde(deserialize_with = "present")]
    max_error_m: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[serde(deserialize_with = "present")]
    final_error_m: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[serde(deserialize_with = "present")]
    heading_rmse_rad: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    rpe: Option<Vec<Rpe>>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    relations: Option<RelationErrors>,
    #[serde(deserialize_with = "crate::json_number::number")]
    chi2_per_dof: f64,
    solves: u32,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    map: Option<MapMetrics>,
}

/// Reads a number that is there, `null` (NaN) included; an absent one is `None` (the
/// field's default).
fn present<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Option<f64>, D::Error> {
    crate::json_number::number(d).map(Some)
}

impl TrajectoryFile {
    /// `t` as written, with its truth-based errors when `truth` says they were measured.
    fn of(t: TrajectoryMetrics, truth: bool) -> Self {
        let measured = |v: f64| truth.then_some(v);
        Self {
            poses: t.poses,
            ate_rmse_m: measured(t.ate_rmse_m),
            max_error_m: measured(t.max_error_m),
            final_error_m: measured(t.final_error_m),
            heading_rmse_rad: measured(t.heading_rmse_rad),
            rpe: truth.then_some(t.rpe),
            relations: t.relations,
        }
    }
}

impl From<TrajectoryFile> for TrajectoryMetrics {
    fn from(t: TrajectoryFile) -> Self {
        let number = |v: Option<f64>| v.unwrap_or(f64::NAN);
        Self {
            poses: t.poses,
            ate_rmse_m: number(t.ate_rmse_m),
            max_error_m: number(t.max_error_m),
            final_error_m: number(t.final_error_m),
            heading_rmse_rad: number(t.heading_rmse_rad),
            rpe: t.rpe.unwrap_or_default(),
            relations: t.relations,
        }
    }
}

impl SmoothedFile {
    /// `s` as written, with its truth-based errors and map when `truth` says they were
    /// measured.
    fn of(s: SmoothedMetrics, truth: bool) -> Self {
        let t = TrajectoryFile::of(s.trajectory, truth);
        Self {
            poses: t.poses,
            ate_rmse_m: t.ate_rmse_m,
            max_error_m: t.max_error_m,
            final_error_m: t.final_error_m,
            heading_rmse_rad: t.heading_rmse_rad,
            rpe: t.rpe,
            relations: t.relations,
            chi2_per_dof: s.chi2_per_dof,
            solves: s.solves,
            map: truth.then_some(s.map),
        }
    }
}

impl From<SmoothedFile> for SmoothedMetrics {
    fn from(s: SmoothedFile) -> Self {
        let trajectory = TrajectoryFile {
            poses: s.poses,
            ate_rmse_m: s.ate_rmse_m,
            max_error_m: s.max_error_m,
            final_error_m: s.final_error_m,
            heading_rmse_rad: s.heading_rmse_rad,
            rpe: s.rpe,
            relations: s.relations,
        };
        Self {
            trajectory: trajectory.into(),
            chi2_per_dof: s.chi2_per_dof,
            solves: s.solves,
            map: s.map.unwrap_or_else(MapMetrics::unmeasured),
        }
    }
}

impl From<Metrics> for MetricsFile {
    fn from(m: Metrics) -> Self {
        let truth = m.ground_truth;
        let warnings = Warnings::of(&m);
        Self {
            complete: m.complete,
            ground_truth: truth,
            alignment: m.alignment,
            scored_at: m.scored_at,
            estimate: TrajectoryFile::of(m.estimate, truth),
            dead_reckoning: TrajectoryFile::of(m.dead_reckoning, truth),
            reference: m.reference,
            smoothed: m.smoothed.map(|s| SmoothedFile::of(s, truth)),
            consistency: truth.then_some(m.consistency),
            map: truth.then_some(m.map),
            filter: m.filter,
            inputs: m.inputs,
            cost: m.cost,
            warnings,
        }
    }
}

impl From<MetricsFile> for Metrics {
    fn from(f: MetricsFile) -> Self {
        Self {
            complete: f.complete,
            ground_truth: f.ground_truth,
            alignment: f.alignment,
            scored_at: f.scored_at,
            estimate: f.estimate.into(),
            dead_reckoning: f.dead_reckoning.into(),
            reference: f.reference,
            smoothed: f.smoothed.map(SmoothedMetrics::from),
            consistency: f.consistency.unwrap_or_else(Consistency::unmeasured),
            map: f.map.unwrap_or_else(MapMetrics::unmeasured),
            filter: f.filter,
            inputs: f.inputs,
            cost: f.cost,
        }
    }
}

/// [`Metrics`] is written as its [`MetricsFile`].
impl Serialize for Metrics {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        MetricsFile::from(self.clone()).serialize(serializer)
    }
}

/// [`Metrics`] is read back from its [`MetricsFile`].
impl<'de> Deserialize<'de> for Metrics {
    fn deserialize<D: serde::Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        MetricsFile::deserialize(deserializer).map(Self::from)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::align::Se2;
    use crate::recording::{Estimate, Recording, StampedPose, StatusSample};
    use crate::relations::Relation;
    use fastslam_protocol::MapLandmark;
    use serde_json::Value;

    fn pose(stamp_ns: u64, x: f64, y: f64, theta: f64) -> StampedPose {
        StampedPose {
            stamp_ns,
            x,
            y,
            theta,
        }
    }

    /// A drive around a circle: truth every 0.1 s, an estimate every 0.2 s (a little
    /// off), dead reckoning drifting, a smoothed trajectory, maps and status: everything a
    /// run records, with or without ground truth.
    fn recording(without_truth: bool) -> Recording {
        let on_circle = |k: u64| {
            let a = k as f64 * 0.02;
            pose(k * 100_000_000, 10.0 * a.sin(), 10.0 - 10.0 * a.cos(), a)
        };
        let truth: Vec<StampedPose> = (0..300).map(on_circle).collect();
        let estimates = (truth.iter().step_by(2))
            .map(|p| Estimate {
                pose: pose(p.stamp_ns, p.x + 0.05, p.y, p.theta),
                covariance: [0.01, 0.0, 0.0, 0.0, 0.01, 0.0, 0.0, 0.0, 0.001],
            })
            .collect();
        let dead_reckoning = (truth.iter())
            .map(|p| pose(p.stamp_ns, p.x * 1.02, p.y, p.theta * 1.01))
            .collect();
        let landmark = |x: f64, y: f64| MapLandmark {
            x,
            y,
            ..Default::default()
        };
        Recording {
            without_truth,
            truth: if without_truth {
                Vec::new()
            } else {
                truth.clone()
            },
            true_map: if without_truth {
                Vec::new()
            } else {
                vec![landmark(3.0, 4.0)]
            },
            estimates,
            dead_reckoning,
            smoothed: truth.iter().step_by(5).copied().collect(),
            smoothed_fit: Some((1.1, 2)),
            smoothed_map: vec![landmark(3.0, 4.1)],
            map: vec![landmark(3.1, 4.0)],
            status: vec![StatusSample {
                stamp_ns: 200_000_000,
                n_eff: 5.0,
                particles: 10,
                distinct: 6,
                resampled: true,
                landmarks: 1,
                step_time_s: 0.001,
                nis: 1.2,
                nis_high: false,
                nis_pose: false,
                noise_profile: [0.1, 0.5, 0.2, 0.05],
                noise_fitted: [0.4, 1.3, 0.2, 0.05],
                noise_fit: 1,
                noise_suspect: 0,
            }],
            latencies: vec![(200_000_000, 0.003)],
            ..Default::default()
        }
    }

    /// The metrics of `rec` as `metrics.json` holds them, and its text.
    fn written(mut rec: Recording, relations: Option<&[Relation]>) -> (Metrics, Value, String) {
        let mut m = Metrics::compute(&rec, true, Alignment::default(), ScoreAt::default())
            .with_smoothed(&mut rec);
        if let Some(relations) = relations {
            m = m.with_relations(&rec, relations, 1000.0, &Se2::IDENTITY);
        }
        let text = serde_json::to_string_pretty(&m).unwrap();
        (m, serde_json::from_str(&text).unwrap(), text)
    }

    /// The keys of a JSON object, in the order `text` (pretty-printed) writes them at
    /// `indent` spaces.
    fn keys_in_order(text: &str, indent: usize) -> Vec<String> {
        let prefix = format!("{}\"", " ".repeat(indent));
        (text.lines())
            .filter_map(|l| l.strip_prefix(&prefix))
            .filter_map(|l| l.split_once('"').map(|(k, _)| k.to_string()))
            .collect()
    }

    /// Asserts that `m` writes `text` again: the same keys in the same order, the same
    /// values (numbers to the last few bits: reading a float back from its text may not
    /// give its last bit).
    fn assert_same(m: &Metrics, text: &str) {
        fn same(a: &Value, b: &Value) -> bool {
            match (a, b) {
                (Value::Number(x), Value::Number(y)) => {
                    let (x, y) = (x.as_f64().unwrap(), y.as_f64().unwrap());
                    (x - y).abs() <= 1e-14 * x.abs().max(y.abs())
                }
                (Value::Array(x), Value::Array(y)) => {
                    x.len() == y.len() && x.iter().zip(y).all(|(x, y)| same(x, y))
                }
                (Value::Object(x), Value::Object(y)) => {
                    x.len() == y.len()
                        && x.iter().all(|(k, v)| y.get(k).is_some_and(|w| same(v, w)))
                }
                _ => a == b,
            }
        }
        let again = serde_json::to_string_pretty(m).unwrap();
        let keys = |text: &str| -> Vec<String> {
            (text.lines())
                .filter_map(|l| l.trim_start().strip_prefix('"'))
                .filter_map(|l| l.split_once('"').map(|(k, _)| k.to_string()))
                .collect()
        };
        assert_eq!(keys(&again), keys(text));
        let (a, b): (Value, Value) = (
            serde_json::from_str(&again).unwrap(),
            serde_json::from_str(text).unwrap(),
        );
        assert!(same(&a, &b), "{again}\nis not\n{text}");
    }

    fn keys(v: &Value) -> Vec<&str> {
        let mut keys: Vec<&str> = v.as_object().unwrap().keys().map(String::as_str).collect();
        keys.sort_unstable();
        keys
    }

    #[test]
    fn a_run_with_truth_writes_every_truth_based_key_in_order() {
        let (m, json, text) = written(recording(false), None);
        assert!(m.ground_truth && m.estimate.ate_rmse_m < 0.06);
        assert_eq!(
            keys_in_order(&text, 2),
            [
                "complete",
                "ground_truth",
                "alignment",
                "scored_at",
                "estimate",
                "dead_reckoning",
                "smoothed",
                "consistency",
                "map",
                "filter",
                "inputs",
                "cost",
                "warnings"
            ]
        );
        let trajectory = [
            "poses",
            "ate_rmse_m",
            "max_error_m",
            "final_error_m",
            "heading_rmse_rad",
            "rpe",
        ];
        let section = |from: &str, to: &str| {
            let at = |key: &str| text.find(&format!("\n  \"{key}\"")).unwrap();
            &text[at(from)..at(to)]
        };
        let estimate = section("estimate", "dead_reckoning");
        assert_eq!(keys_in_order(estimate, 4), trajectory);
        let smoothed = section("smoothed", "consistency");
        let mut with_fit = trajectory.to_vec();
        with_fit.extend(["chi2_per_dof", "solves", "map"]);
        assert_eq!(keys_in_order(smoothed, 4), with_fit);
        assert_eq!(json["ground_truth"], true);
        assert_eq!(json["map"]["truth"], 1);
        let back: Metrics = serde_json::from_str(&text).unwrap();
        assert_same(&back, &text);
    }

    #[test]
    fn a_run_without_truth_leaves_out_what_needs_truth() {
        let (m, json, text) = written(recording(true), None);
        assert!(!m.ground_truth);
        assert_eq!(json["ground_truth"], false);
        for absent in ["consistency", "map", "reference"] {
            assert!(json.get(absent).is_none(), "{absent} in {text}");
        }
        assert_eq!(keys(&json["estimate"]), ["poses"]);
        assert_eq!(json["estimate"]["poses"], 150, "every estimate");
        assert_eq!(keys(&json["dead_reckoning"]), ["poses"]);
        assert_eq!(keys(&json["smoothed"]), ["chi2_per_dof", "poses", "solves"]);
        assert_eq!(json["smoothed"]["poses"], 60);
        // What needs no truth is all there.
        assert_eq!(json["filter"]["steps"], 1);
        assert_eq!(json["filter"]["nis_mean"], 1.2);
        assert_eq!(json["cost"]["latency_ms"]["samples"], 1);
        assert!(json["inputs"]["rejected_total"].is_number());
        for absent in ["ate_rmse_m", "rpe", "nees", "rmse_m", "true_map"] {
            assert!(!text.contains(absent), "absent, not null: {text}");
        }
        let back: Metrics = serde_json::from_str(&text).unwrap();
        assert!(!back.ground_truth && back.estimate.ate_rmse_m.is_nan());
        assert_same(&back, &text);
        back.require_a_pose(std::path::Path::new("run"))
            .expect("it has poses");
    }

    #[test]
    fn a_file_without_the_ground_truth_key_has_truth() {
        let (_, _, text) = written(recording(false), None);
        let older = text.replace("  \"ground_truth\": true,\n", "");
        assert_ne!(older, text);
        let m: Metrics = serde_json::from_str(&older).unwrap();
        assert!(m.ground_truth);
        assert_same(&m, &text);
    }

    /// The relations between every estimate and the one `ahead` further on, exactly as
    /// `track` moved, at times on a clock whose epoch is 1000 s.
    fn relations_of(track: &[StampedPose], ahead: usize) -> Vec<Relation> {
        let time = |p: &StampedPose| 1000.0 + p.stamp_ns as f64 * 1e-9;
        (track.iter().zip(&track[ahead..]))
            .map(|(a, b)| {
                let moved = Se2::of(a).inverse().compose(&Se2::of(b));
                Relation {
                    t1_s: time(a),
                    t2_s: time(b),
                    dx: moved.x,
                    dy: moved.y,
                    dtheta: moved.theta,
                }
            })
            .collect()
    }

    #[test]
    fn relations_score_the_estimate_the_smoothed_trajectory_and_dead_reckoning() {
        for without_truth in [false, true] {
            let rec = recording(without_truth);
            let estimates: Vec<StampedPose> = rec.estimates.iter().map(|e| e.pose).collect();
            let relations = relations_of(&estimates, 5);
            let (m, json, text) = written(rec, Some(&relations));
            let e = m.estimate.relations.unwrap();
            assert_eq!(e.count, relations.len());
            assert!(e.trans_mean_m < 1e-9 && e.rot_mean_deg < 1e-9, "{e:?}");
            // Dead reckoning drifts: its motions are off.
            let d = m.dead_reckoning.relations.unwrap();
            assert_eq!(d.count, relations.len());
            assert!(d.trans_mean_m > 1e-3 && d.rot_mean_deg > 1e-3, "{d:?}");
            // The smoothed trajectory (every 0.5 s) has poses within 0.1 s of some of the
            // times only.
            let s = m.smoothed.as_ref().unwrap().trajectory.relations.unwrap();
            assert!(s.count > 0 && s.count < relations.len(), "{s:?}");
            let fields = [
                "count",
                "rot_mean_deg",
                "rot_sq_mean_deg2",
                "rot_sq_std_deg2",
                "rot_std_deg",
                "trans_mean_m",
                "trans_sq_mean_m2",
                "trans_sq_std_m2",
                "trans_std_m",
            ];
            for section in [
                &json["estimate"],
                &json["dead_reckoning"],
                &json["smoothed"],
            ] {
                assert_eq!(keys(&section["relations"]), fields, "{text}");
            }
            let back: Metrics = serde_json::from_str(&text).unwrap();
            assert_eq!(back.estimate.relations, m.estimate.relations);
            assert_same(&back, &text);
        }
        let (_, _, text) = written(recording(false), None);
        assert!(!text.contains("relations"), "absent without relations");
    }

    #[test]
    fn relations_on_another_clock_score_nothing() {
        let rec = recording(true);
        let estimates: Vec<StampedPose> = rec.estimates.iter().map(|e| e.pose).collect();
        let mut relations = relations_of(&estimates, 5);
        for r in &mut relations {
            r.t1_s -= 1000.0;
            r.t2_s -= 1000.0;
        }
        let (m, json, _) = written(rec, Some(&relations));
        assert_eq!(m.estimate.relations, None);
        assert!(json["estimate"].get("relations").is_none());
    }
}
