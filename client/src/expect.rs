//! Expectations on a run's metrics and their verdict: `--expect "estimate.ate_rmse_m < 0.5"`
//! compares a number of `metrics.json`, named by its dotted path, with a bound. After
//! scoring, each expectation gives one line (✓/✗, the measured value, the bound) and, with
//! `--junit`, one `<testcase>` of a JUnit XML report; the run passes when every stream
//! ended and every expectation holds. `METRICS.md` documents the paths.

use crate::Metrics;
use crate::metrics::{Alignment, ScoreAt, SmoothedMetrics};
use crate::recording::Recording;
use crate::reference::ReferenceMetrics;
use crate::relations::RelationErrors;
use anyhow::Context;
use serde_json::Value;
use std::fmt;
use std::path::{Path, PathBuf};
use std::sync::LazyLock;

/// Flags that judge a run: expectations and a JUnit report (the client's, and those
/// `run`, `replay` and `test` pass on to it).
#[derive(Debug, Clone, Default, clap::Args)]
pub struct JudgeArgs {
    /// An expectation on a number of metrics.json, by its dotted path, e.g.
    /// "estimate.ate_rmse_m < 0.5" or "consistency.nees_within_95 >= 0.6" (repeatable;
    /// operators <, <=, >, >=, ==, !=). After scoring, one line per expectation; the run
    /// fails (exit status 1) when one does not hold or a stream did not end. An unknown
    /// path or a malformed expression is refused at start-up.
    #[arg(long = "expect", value_name = "EXPR")]
    pub expect: Vec<String>,
    /// Write a JUnit XML report here: one test case per expectation, and one for "every
    /// stream ended".
    #[arg(long, value_name = "FILE")]
    pub junit: Option<PathBuf>,
}

impl JudgeArgs {
    /// True when the run is judged (an expectation or a JUnit report was asked for).
    pub fn on(&self) -> bool {
        !self.expect.is_empty() || self.junit.is_some()
    }

    /// The expectations, checked, and the JUnit report's folder checked to exist (so
    /// that a run is not lost to a report it cannot write at the end).
    ///
    /// # Errors
    /// One line naming every malformed expression and unknown path, or the missing folder.
    pub fn expectations(&self) -> anyhow::Result<Expectations> {
        if let Some(junit) = &self.junit {
            let folder = junit
                .parent()
                .filter(|f| !f.as_os_str().is_empty())
                .unwrap_or(std::path::Path::new("."));
            anyhow::ensure!(
                folder.is_dir(),
                "--junit {}: folder {} does not exist",
                junit.display(),
                folder.display()
            );
        }
        Expectations::parse(&self.expect)
    }

    /// These flags with the expectation `default` first, unless one of theirs names the
    /// same number of metrics.json: a default that the user's own expectation replaces.
    ///
    /// # Errors
    /// As [`JudgeArgs::expectations`], and when `default` is malformed.
    pub fn with_default(&self, default: &str) -> anyhow::Result<Self> {
        let theirs = self.expectations()?;
        let default_path = Expectation::parse(default)
            .map_err(anyhow::Error::msg)?
            .path;
        let mut judge = self.clone();
        if !theirs.0.iter().any(|e| e.path == default_path) {
            judge.expect.insert(0, default.to_string());
        }
        Ok(judge)
    }

    /// The same flags, for the client a launcher starts.
    pub fn flags(&self) -> Vec<String> {
        let mut flags: Vec<String> = self
            .expect
            .iter()
            .map(|e| format!("--expect={e}"))
            .collect();
        flags.extend(
            self.junit
                .iter()
                .map(|j| format!("--junit={}", j.display())),
        );
        flags
    }
}

/// A comparison operator of an expectation.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Op {
    /// `<`
    Lt,
    /// `<=`
    Le,
    /// `>`
    Gt,
    /// `>=`
    Ge,
    /// `==`
    Eq,
    /// `!=`
    Ne,
}

/// The operators with their symbols, two-character ones first (so `<=` is not read as `<`).
const OPS: [(&str, Op); 6] = [
    ("<=", Op::Le),
    (">=", Op::Ge),
    ("==", Op::Eq),
    ("!=", Op::Ne),
    ("<", Op::Lt),
    (">", Op::Gt),
];

impl Op {
    /// Its symbol.
    pub fn symbol(self) -> &'static str {
        OPS.iter()
            .find(|(_, op)| *op == self)
            .map_or("?", |(s, _)| s)
    }

    /// Whether `value op bound` holds.
    pub fn holds(self, value: f64, bound: f64) -> bool {
        match self {
            Self::Lt => value < bound,
            Self::Le => value <= bound,
            Self::Gt => value > bound,
            Self::Ge => value >= bound,
            Self::Eq => value == bound,
            Self::Ne => value != bound,
        }
    }
}

/// One expectation: the number at `path` of metrics.json compared with `bound`.
#[derive(Debug, Clone, PartialEq)]
pub struct Expectation {
    /// Dotted path into metrics.json (`estimate.ate_rmse_m`; list items by index,
    /// `estimate.rpe.0.translation_rmse_m`).
    pub path: String,
    /// The comparison.
    pub op: Op,
    /// The number compared with.
    pub bound: f64,
}

impl fmt::Display for Expectation {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} {} {}", self.path, self.op.symbol(), self.bound)
    }
}

impl Expectation {
    /// Reads `PATH OP NUMBER` and checks that metrics.json has a number at `PATH`.
    ///
    /// # Errors
    /// What is wrong with it, quoting it.
    pub fn parse(text: &str) -> Result<Self, String> {
        let wrong = |why: String| format!("\"{text}\": {why}");
        let Some((at, symbol, op)) = OPS
            .iter()
            .filter_map(|(s, op)| text.find(s).map(|at| (at, *s, *op)))
            .min_by_key(|(at, s, _)| (*at, usize::MAX - s.len()))
        else {
            return Err(wrong("no comparison (<, <=, >, >=, ==, !=)".into()));
        };
        let path = text[..at].trim();
        let bound = text[at + symbol.len()..].trim();
        if path.is_empty() {
            return Err(wrong("no metrics.json path before the comparison".into()));
        }
        let bound = match bound.parse::<f64>() {
            Ok(b) if b.is_finite() => b,
            _ => return Err(wrong(format!("\"{bound}\" is not a finite number"))),
        };
        match lookup(&TEMPLATE, path) {
            Some(Value::Number(_) | Value::Null) => {}
            Some(Value::Object(fields)) => {
                let names: Vec<&str> = fields.keys().map(String::as_str).collect();
                return Err(wrong(format!(
                    "{path} is a section, not a number (it has {})",
                    names.join(", ")
                )));
            }
            Some(_) => return Err(wrong(format!("{path} is not a number"))),
            None => return Err(wrong(format!("metrics.json has no field {path}"))),
        }
        Ok(Self {
            path: path.to_string(),
            op,
            bound,
        })
    }

    /// What `metrics` (metrics.json as JSON) holds at this path.
    pub fn measure(&self, metrics: &Value) -> Measured {
        match lookup(metrics, &self.path) {
            Some(Value::Number(n)) => n.as_f64().map_or(Measured::NotANumber, Measured::Value),
            Some(_) => Measured::NotANumber,
            None => Measured::NotMeasured,
        }
    }
}

/// metrics.json of an empty run with ground truth, with every optional part: the
/// `reference` and `smoothed` sections and each trajectory's `relations`. The shape every
/// run's metrics have at most, numbers (or `null`) where a run has numbers.
static TEMPLATE: LazyLock<Value> = LazyLock::new(|| {
    let mut m = Metrics::compute(
        &Recording::default(),
        false,
        Alignment::default(),
        ScoreAt::default(),
    );
    let relations = RelationErrors {
        count: 0,
        trans_mean_m: f64::NAN,
        trans_std_m: f64::NAN,
        trans_sq_mean_m2: f64::NAN,
        trans_sq_std_m2: f64::NAN,
        rot_mean_deg: f64::NAN,
        rot_std_deg: f64::NAN,
        rot_sq_mean_deg2: f64::NAN,
        rot_sq_std_deg2: f64::NAN,
    };
    m.estimate.relations = Some(relations);
    m.dead_reckoning.relations = Some(relations);
    m.reference = Some(ReferenceMetrics::default());
    m.smoothed = Some(SmoothedMetrics {
        trajectory: m.estimate.clone(),
        chi2_per_dof: f64::NAN,
        solves: 0,
        map: m.map.clone(),
    });
    serde_json::to_value(&m).unwrap_or(Value::Null)
});

/// The value at dotted `path` of `json` (object keys, list indices).
fn lookup<'a>(json: &'a Value, path: &str) -> Option<&'a Value> {
    path.split('.').try_fold(json, |v, key| match v {
        Value::Object(fields) => fields.get(key),
        Value::Array(items) => items.get(key.parse::<usize>().ok()?),
        _ => None,
    })
}

/// What a run measured for an expectation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Measured {
    /// A number.
    Value(f64),
    /// `null` (NaN: nothing to measure) or not a number.
    NotANumber,
    /// The field is absent from this run's metrics (`reference` without landmark ids,
    /// `smoothed` without the smoothing back-end, `relations` without a relations file,
    /// the truth-based errors without ground truth).
    NotMeasured,
}

impl fmt::Display for Measured {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Value(v) => write!(f, "measured {}", number(*v)),
            Self::NotANumber => write!(f, "measured null (NaN: nothing to measure)"),
            Self::NotMeasured => write!(f, "not measured"),
        }
    }
}

/// A number with six significant digits, plainly written when it is not tiny or huge.
fn number(v: f64) -> String {
    if v == v.trunc() && v.abs() < 1e15 {
        return format!("{v:.0}");
    }
    if v.abs() < 1e-4 || v.abs() >= 1e15 {
        return format!("{v:.5e}");
    }
    let decimals = (5 - v.abs().log10().floor() as i32).max(0) as usize;
    let text = format!("{v:.decimals$}");
    text.trim_end_matches('0').trim_end_matches('.').to_string()
}

/// The expectations of a run, checked against the shape of metrics.json.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Expectations(pub Vec<Expectation>);

impl Expectations {
    /// Reads every expression.
    ///
    /// # Errors
    /// One line naming every malformed expression and unknown path.
    pub fn parse<S: AsRef<str>>(exprs: &[S]) -> anyhow::Result<Self> {
        let (ok, wrong): (Vec<_>, Vec<_>) = exprs
            .iter()
            .map(|e| Expectation::parse(e.as_ref()))
            .partition(Result::is_ok);
        if !wrong.is_empty() {
            let problems: Vec<String> = wrong.into_iter().filter_map(Result::err).collect();
            anyhow::bail!("--expect: {}", problems.join("; "));
        }
        Ok(Self(ok.into_iter().filter_map(Result::ok).collect()))
    }

    /// Judges `metrics`.
    pub fn judge(&self, metrics: &Metrics) -> Verdict {
        let json = serde_json::to_value(metrics).unwrap_or(Value::Null);
        Verdict {
            complete: metrics.complete,
            checks: (self.0.iter())
                .map(|e| Check {
                    expectation: e.clone(),
                    measured: e.measure(&json),
                })
                .collect(),
        }
    }

    /// Judges the metrics.json of the run folder `out`.
    ///
    /// # Errors
    /// When it cannot be read.
    pub fn judge_folder(&self, out: &Path) -> anyhow::Result<Verdict> {
        Ok(self.judge(&Metrics::read(&out.join("metrics.json"))?))
    }
}

/// One expectation and what the run measured for it.
#[derive(Debug, Clone, PartialEq)]
pub struct Check {
    /// The expectation.
    pub expectation: Expectation,
    /// What the run measured.
    pub measured: Measured,
}

impl Check {
    /// True when the measured value is a number that holds.
    pub fn passed(&self) -> bool {
        match self.measured {
            Measured::Value(v) => self.expectation.op.holds(v, self.expectation.bound),
            Measured::NotANumber | Measured::NotMeasured => false,
        }
    }
}

impl fmt::Display for Check {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mark = if self.passed() { '✓' } else { '✗' };
        write!(f, "{mark} {}  ({})", self.expectation, self.measured)
    }
}

/// The name of the check that every stream ended (`metrics.complete`).
pub const COMPLETE: &str = "every stream ended";

/// How a run fared against its expectations.
#[derive(Debug, Clone, PartialEq)]
pub struct Verdict {
    /// Every stream ended (`metrics.complete`).
    pub complete: bool,
    /// Each expectation with its measured value.
    pub checks: Vec<Check>,
}

impl Verdict {
    /// True when every stream ended and every expectation holds.
    pub fn passed(&self) -> bool {
        self.complete && self.checks.iter().all(Check::passed)
    }

    /// One line per check: every stream ended, then each expectation.
    pub fn lines(&self) -> Vec<String> {
        let mark = if self.complete { '✓' } else { '✗' };
        let mut lines = vec![format!("{mark} {COMPLETE}")];
        lines.extend(self.checks.iter().map(Check::to_string));
        lines
    }

    /// `Ok` when the run passed, else an error naming what failed.
    ///
    /// # Errors
    /// `failed expectations: …` with each failure and its measured value.
    pub fn into_result(self) -> anyhow::Result<()> {
        if self.passed() {
            return Ok(());
        }
        let mut failed: Vec<String> = (!self.complete)
            .then(|| COMPLETE.to_string())
            .into_iter()
            .collect();
        failed.extend(
            (self.checks.iter())
                .filter(|c| !c.passed())
                .map(|c| format!("{} ({})", c.expectation, c.measured)),
        );
        anyhow::bail!("failed expectations: {}", failed.join("; "))
    }

    /// A JUnit XML report: a test suite `suite` with one test case for "every stream
    /// ended" and one per expectation, a failed one with a `<failure>` holding what was
    /// measured.
    pub fn junit(&self, suite: &str) -> String {
        let incomplete = "the run ended before every stream did (metrics.complete is false)";
        let mut cases = vec![(
            COMPLETE.to_string(),
            (!self.complete).then(|| incomplete.to_string()),
        )];
        cases.extend(self.checks.iter().map(|c| {
            let failure =
                (!c.passed()).then(|| format!("{}, expected {}", c.measured, c.expectation));
            (c.expectation.to_string(), failure)
        }));
        let failures = cases.iter().filter(|(_, f)| f.is_some()).count();
        let suite = escape(suite);
        let mut xml = format!(
            "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<testsuites tests=\"{n}\" failures=\"{failures}\">\n  <testsuite name=\"{suite}\" tests=\"{n}\" failures=\"{failures}\">\n",
            n = cases.len()
        );
        for (name, failure) in &cases {
            let name = escape(name);
            match failure {
                None => xml += &format!("    <testcase classname=\"{suite}\" name=\"{name}\"/>\n"),
                Some(why) => {
                    let why = escape(why);
                    xml += &format!(
                        "    <testcase classname=\"{suite}\" name=\"{name}\">\n      <failure message=\"{why}\">{why}</failure>\n    </testcase>\n"
                    );
                }
            }
        }
        xml + "  </testsuite>\n</testsuites>\n"
    }

    /// Writes [`Verdict::junit`] to `path`.
    ///
    /// # Errors
    /// When the file cannot be written.
    pub fn write_junit(&self, path: &Path, suite: &str) -> anyhow::Result<()> {
        std::fs::write(path, self.junit(suite))
            .with_context(|| format!("writing the JUnit report {}", path.display()))
    }
}

/// `text` with the five XML special characters escaped.
fn escape(text: &str) -> String {
    text.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
        .replace('\'', "&apos;")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn metrics() -> Metrics {
        let mut m = Metrics::compute(
            &Recording::default(),
            true,
            Alignment::default(),
            ScoreAt::default(),
        );
        m.estimate.ate_rmse_m = 0.25;
        m.estimate.poses = 1200;
        m
    }

    #[test]
    fn a_junit_report_in_a_missing_folder_is_refused_at_start() {
        let missing = std::env::temp_dir().join("fastslam-no-such-folder-7d1f/report.xml");
        let judge = JudgeArgs {
            expect: Vec::new(),
            junit: Some(missing),
        };
        let err = judge.expectations().unwrap_err().to_string();
        assert!(
            err.starts_with("--junit ") && err.contains("does not exist"),
            "{err}"
        );
        let here = JudgeArgs {
            expect: Vec::new(),
            junit: Some(std::env::temp_dir().join("report.xml")),
        };
        here.expectations().unwrap();
        let bare = JudgeArgs {
            expect: Vec::new(),
            junit: Some("report.xml".into()),
        };
        bare.expectations().unwrap();
    }

    #[test]
    fn a_default_expectation_comes_first_unless_one_names_its_number() {
        let default = "inputs.rejected_total == 0";
        let judge = |expect: &[&str]| JudgeArgs {
            expect: expect.iter().map(ToString::to_string).collect(),
            junit: None,
        };
        let added = judge(&["estimate.ate_rmse_m < 0.5"]).with_default(default);
        assert_eq!(
            added.unwrap().expect,
            [default, "estimate.ate_rmse_m < 0.5"]
        );
        let replaced = judge(&["inputs.rejected_total <= 3"]).with_default(default);
        assert_eq!(replaced.unwrap().expect, ["inputs.rejected_total <= 3"]);
        assert!(judge(&["nonsense < 1"]).with_default(default).is_err());
    }

    #[test]
    fn expressions_read_with_every_operator_and_spacing() {
        for (text, op) in [
            ("estimate.ate_rmse_m<0.5", Op::Lt),
            ("estimate.ate_rmse_m <= 0.5", Op::Le),
            ("estimate.ate_rmse_m>0.5", Op::Gt),
            (" estimate.ate_rmse_m >=0.5 ", Op::Ge),
            ("estimate.ate_rmse_m == 0.5", Op::Eq),
            ("estimate.ate_rmse_m != 5e-1", Op::Ne),
        ] {
            let e = Expectation::parse(text).unwrap();
            assert_eq!(
                (e.path.as_str(), e.op, e.bound),
                ("estimate.ate_rmse_m", op, 0.5),
                "{text}"
            );
        }
        let rpe = Expectation::parse("estimate.rpe.0.translation_rmse_m < 1").unwrap();
        assert_eq!(rpe.to_string(), "estimate.rpe.0.translation_rmse_m < 1");
        assert!(
            Expectation::parse("reference.ate_rmse_m < 1").is_ok(),
            "an optional section"
        );
    }

    #[test]
    fn malformed_expressions_and_unknown_paths_are_refused_all_in_one_line() {
        let err = Expectations::parse(&[
            "nonsense.path < 1",
            "estimate.ate_rmse_m",
            "estimate.ate_rmse_m < lots",
            "estimate < 1",
            "complete == 1",
            "estimate.ate_rmse_m < 0.5",
        ])
        .unwrap_err()
        .to_string();
        assert!(!err.contains('\n'), "{err}");
        for part in [
            "metrics.json has no field nonsense.path",
            "\"estimate.ate_rmse_m\": no comparison",
            "\"lots\" is not a finite number",
            "estimate is a section, not a number (it has ate_rmse_m, final_error_m",
            "complete is not a number",
        ] {
            assert!(err.contains(part), "{part} in {err}");
        }
        assert!(!err.contains("< 0.5"), "a good one is not listed: {err}");
    }

    #[test]
    fn a_verdict_fails_on_a_missed_bound_a_null_or_an_absent_section() {
        let e = Expectations::parse(&[
            "estimate.ate_rmse_m < 0.5",
            "estimate.poses >= 1000",
            "estimate.ate_rmse_m < 0.1",
            "map.rmse_m < 1",
            "reference.ate_rmse_m < 1",
        ])
        .unwrap();
        let v = e.judge(&metrics());
        let passed: Vec<bool> = v.checks.iter().map(Check::passed).collect();
        assert_eq!(passed, [true, true, false, false, false]);
        assert_eq!(
            v.checks[3].measured,
            Measured::NotANumber,
            "no map: NaN, written null"
        );
        assert_eq!(v.checks[4].measured, Measured::NotMeasured);
        assert_eq!(v.lines()[0], "✓ every stream ended");
        assert_eq!(v.lines()[3], "✗ estimate.ate_rmse_m < 0.1  (measured 0.25)");
        let err = v.clone().into_result().unwrap_err().to_string();
        assert!(
            err.starts_with(
                "failed expectations: estimate.ate_rmse_m < 0.1 (measured 0.25); map.rmse_m"
            ),
            "{err}"
        );
        assert!(
            err.contains("reference.ate_rmse_m < 1 (not measured)"),
            "{err}"
        );

        let mut incomplete = metrics();
        incomplete.complete = false;
        let v = Expectations::default().judge(&incomplete);
        assert!(!v.passed());
        assert_eq!(
            v.into_result().unwrap_err().to_string(),
            "failed expectations: every stream ended"
        );
        assert!(Expectations::default().judge(&metrics()).passed());
    }

    #[test]
    fn without_ground_truth_its_metrics_are_not_measured() {
        let rec = Recording {
            without_truth: true,
            ..Default::default()
        };
        let m = Metrics::compute(&rec, true, Alignment::default(), ScoreAt::default());
        let e = Expectations::parse(&[
            "estimate.ate_rmse_m < 1",
            "map.rmse_m < 1",
            "consistency.nees_within_95 >= 0.5",
            "estimate.relations.trans_mean_m < 0.1",
            "smoothed.relations.rot_mean_deg < 1",
            "estimate.poses >= 0",
        ])
        .unwrap();
        let v = e.judge(&m);
        let measured: Vec<Measured> = v.checks.iter().map(|c| c.measured).collect();
        let mut expected = vec![Measured::NotMeasured; 5];
        expected.push(Measured::Value(0.0));
        assert_eq!(measured, expected);
        assert_eq!(v.lines()[1], "✗ estimate.ate_rmse_m < 1  (not measured)");
        let err = v.into_result().unwrap_err().to_string();
        assert!(
            err.starts_with("failed expectations: estimate.ate_rmse_m < 1 (not measured); "),
            "{err}"
        );
        assert!(
            Expectation::parse("estimate.relations.nonsense < 1").is_err(),
            "relations have their fields only"
        );
    }

    #[test]
    fn junit_escapes_and_counts_failures() {
        let v = Expectations::parse(&["estimate.ate_rmse_m < 0.5", "estimate.ate_rmse_m > 1"])
            .unwrap()
            .judge(&metrics());
        let xml = v.junit("a&b");
        assert!(
            xml.contains("<testsuite name=\"a&amp;b\" tests=\"3\" failures=\"1\">"),
            "{xml}"
        );
        assert!(
            xml.contains("name=\"estimate.ate_rmse_m &lt; 0.5\"/>"),
            "{xml}"
        );
        assert!(
            xml.contains(
                "<failure message=\"measured 0.25, expected estimate.ate_rmse_m &gt; 1\">"
            ),
            "{xml}"
        );
        assert_eq!(escape("<'\"&>"), "&lt;&apos;&quot;&amp;&gt;");
    }

    #[test]
    fn numbers_show_six_significant_digits() {
        assert_eq!(number(1200.0), "1200");
        assert_eq!(number(0.041_234_567), "0.0412346");
        assert_eq!(number(123.456_789), "123.457");
        assert_eq!(number(0.5), "0.5");
        assert_eq!(number(1.5e-7), "1.50000e-7");
    }

    #[test]
    fn flags_pass_the_expressions_on_unchanged() {
        let args = JudgeArgs {
            expect: vec!["estimate.poses >= 10".into()],
            junit: Some("out/j.xml".into()),
        };
        assert!(args.on());
        assert_eq!(
            args.flags(),
            ["--expect=estimate.poses >= 10", "--junit=out/j.xml"]
        );
        assert!(!JudgeArgs::default().on());
    }
}
