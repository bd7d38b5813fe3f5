//! The run folder of a real run through the whole stack: `evo` reads our trajectories and
//! agrees with our ATE, the Python `mcap` reader reads `run.mcap` with a message for every
//! pose, truth and odometry sample the client saw, the pictures show the run,
//! `metrics.json` and `metrics.csv` match their documentation (`client/METRICS.md`).
//!
//! One run of the short scenario serves every test of this file.

mod common;

use common::*;
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;

/// The run folder, made once for all tests of this file.
fn run_folder() -> &'static Path {
    static RUN: OnceLock<PathBuf> = OnceLock::new();
    RUN.get_or_init(|| {
        let prefix = prefix("run_folder");
        let out = PathBuf::from(env!("CARGO_TARGET_TMPDIR"))
            .join(&prefix)
            .join("run");
        let result = run_stack(
            &prefix,
            &out,
            &["--scenario", "bailey-short", "--seed", "3"],
        );
        assert_success(&result);
        out
    })
}

#[test]
fn evo_ape_agrees_with_our_ate() {
    let out = run_folder();
    let evo = evo_ape();
    let results = out.with_file_name("ape.zip");
    let _ = std::fs::remove_file(&results);
    let ran = Command::new(&evo)
        .args([
            "tum",
            "truth.tum",
            "estimate.tum",
            "--no_warnings",
            "--silent",
        ])
        .arg("--save_results")
        .arg(&results)
        .current_dir(out)
        .output()
        .unwrap_or_else(|e| {
            panic!(
                "cannot run {} ({e}); evo comes from PyPI into the target dir, or set EVO_APE",
                evo.display()
            )
        });
    assert!(
        ran.status.success(),
        "evo_ape failed: {}",
        String::from_utf8_lossy(&ran.stderr)
    );
    // evo prints 6 decimals; its saved statistics hold the full value.
    let read = Command::new("python3")
        .args([
            "-c",
            "import json, sys, zipfile; \
             print(repr(json.load(zipfile.ZipFile(sys.argv[1]).open('stats.json'))['rmse']))",
        ])
        .arg(&results)
        .output()
        .expect("python3 (which evo needs anyway) reads evo's results");
    let evo_rmse: f64 = String::from_utf8_lossy(&read.stdout)
        .trim()
        .parse()
        .unwrap_or_else(|e| panic!("evo's rmse: {e}: {read:?}"));
    let ours = num(&metrics(out), "/estimate/ate_rmse_m");
    assert!(
        (evo_rmse - ours).abs() < 1e-6,
        "evo_ape RMSE {evo_rmse} vs our ATE {ours}"
    );
}

/// Data lines of a text file (lines not starting with `#`), less `header` lines.
fn rows(path: &Path, header: usize) -> u64 {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    (text.lines().filter(|l| !l.starts_with('#')).count() - header) as u64
}

#[test]
fn run_mcap_holds_what_the_client_saw_in_foxglove_schemas() {
    let out = run_folder();
    let mcap = read_mcap(&out.join("run.mcap"));
    let topics: BTreeSet<String> = mcap["counts"]
        .as_object()
        .unwrap()
        .keys()
        .cloned()
        .collect();
    let mut expected = documented("`run.mcap`");
    assert!(expected.remove("/scan"), "/scan: raw-scan runs only");
    assert!(expected.remove("/grid"), "/grid: raw-scan runs only");
    assert!(
        expected.remove("/particles"),
        "/particles: only when asked for"
    );
    assert_eq!(topics, expected, "run.mcap vs METRICS.md");
    let count = |topic: &str| mcap["counts"][topic].as_u64().unwrap();
    let poses = rows(&out.join("metrics.csv"), 1);
    assert!(poses > 100, "{poses} poses");
    assert_eq!(count("/pose"), poses, "{mcap}");
    assert_eq!(count("/tf"), poses);
    assert_eq!(count("/truth"), rows(&out.join("truth.tum"), 0));
    assert_eq!(
        count("/dead_reckoning"),
        rows(&out.join("dead_reckoning.tum"), 0)
    );
    assert!(count("/map") >= 1 && count("/true_map") >= 1, "{mcap}");
    assert!(count("/observations") >= 1, "{mcap}");
    assert_eq!(count("/metrics"), 1);
    let schema = |topic: &str| mcap["schemas"][topic].as_str().unwrap_or("").to_string();
    assert_eq!(schema("/pose"), "foxglove.Odometry/protobuf");
    assert_eq!(schema("/tf"), "foxglove.FrameTransforms/protobuf");
    for topic in ["/truth", "/dead_reckoning"] {
        assert_eq!(schema(topic), "foxglove.PoseInFrame/protobuf");
    }
    for topic in ["/map", "/true_map", "/observations", "/smoothed_map"] {
        assert_eq!(schema(topic), "foxglove.SceneUpdate/protobuf");
    }
    // A message per solution the service published: at most one per solve (a solve
    // overtaken by the next before the service looked is not sent).
    assert_eq!(schema("/smoothed"), "foxglove.PosesInFrame/protobuf");
    let solves = num(&metrics(out), "/smoothed/solves") as u64;
    assert!((1..=solves).contains(&count("/smoothed")), "{mcap}");
    assert_eq!(count("/smoothed_map"), count("/smoothed"));
    assert_eq!(mcap["encodings"]["/metrics"], "json");
    assert_eq!(
        mcap["metrics"],
        metrics(out),
        "the last message is metrics.json"
    );
}

/// A PNG's size and its pixels as RGB triples.
fn decode_png(path: &Path) -> ((u32, u32), Vec<[u8; 3]>) {
    let bytes = std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut reader = png::Decoder::new(std::io::Cursor::new(bytes))
        .read_info()
        .unwrap_or_else(|e| panic!("{} is not a PNG: {e}", path.display()));
    let mut buf = vec![0; reader.output_buffer_size().expect("PNG buffer size")];
    let info = reader.next_frame(&mut buf).unwrap();
    assert_eq!(info.color_type, png::ColorType::Rgb, "{}", path.display());
    let pixels = buf[..info.buffer_size()]
        .chunks_exact(3)
        .map(|p| [p[0], p[1], p[2]])
        .collect();
    ((info.width, info.height), pixels)
}

#[test]
fn pictures_exist_are_well_formed_and_show_the_trajectory() {
    let out = run_folder();
    for stem in ["trajectory", "errors"] {
        let svg = std::fs::read_to_string(out.join(format!("{stem}.svg"))).unwrap();
        let doc = roxmltree::Document::parse(&svg)
            .unwrap_or_else(|e| panic!("{stem}.svg is not well-formed XML: {e}"));
        assert_eq!(doc.root_element().tag_name().name(), "svg");
        let lines = doc
            .descendants()
            .filter(|n| n.has_tag_name("polyline") || n.has_tag_name("path"))
            .count();
        assert!(lines >= 3, "{stem}.svg draws {lines} lines");
        assert!(
            svg.contains("<text"),
            "{stem}.svg has no text (font missing?)"
        );

        let (size, pixels) = decode_png(&out.join(format!("{stem}.png")));
        assert_eq!(size, (1200, 900), "{stem}.png size");
        let count = |rgb: [u8; 3]| pixels.iter().filter(|p| **p == rgb).count();
        let total = pixels.len();
        let background = count([255, 255, 255]);
        assert!(
            background < total * 98 / 100 && background > total / 3,
            "{stem}.png: {background} of {total} pixels are background"
        );
        // The estimate's colour is drawn along a path, not as a speck.
        let estimate = count([31, 119, 180]);
        assert!(
            estimate > 1000,
            "{stem}.png: {estimate} estimate-coloured pixels"
        );
    }
    let (_, trajectory) = decode_png(&out.join("trajectory.png"));
    let truth_pixels = trajectory.iter().filter(|p| **p == [0, 0, 0]).count();
    assert!(
        truth_pixels > 1000,
        "truth drawn: {truth_pixels} black pixels"
    );
}

/// The first column of the table under `heading` in METRICS.md, without backticks.
fn documented(heading: &str) -> BTreeSet<String> {
    let doc =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("client/METRICS.md"))
            .unwrap();
    let section = doc
        .split("\n## ")
        .find(|s| s.starts_with(heading))
        .unwrap_or_else(|| panic!("no section {heading} in METRICS.md"));
    section
        .lines()
        .filter_map(|l| l.strip_prefix("| `"))
        .filter_map(|l| l.split('`').next())
        .map(str::to_string)
        .collect()
}

/// Every leaf of `v` as a JSON pointer, array indices as `*`.
fn leaves(v: &serde_json::Value, at: String, into: &mut BTreeSet<String>) {
    match v {
        serde_json::Value::Object(m) => {
            for (k, x) in m {
                leaves(x, format!("{at}/{k}"), into);
            }
        }
        serde_json::Value::Array(a) => {
            for x in a {
                leaves(x, format!("{at}/*"), into);
            }
        }
        _ => {
            into.insert(at);
        }
    }
}

#[test]
fn metrics_json_and_csv_are_as_documented() {
    let out = run_folder();
    let m = metrics(out);
    let mut fields = BTreeSet::new();
    leaves(&m, String::new(), &mut fields);
    assert_eq!(
        fields,
        documented("`metrics.json`"),
        "metrics.json vs METRICS.md"
    );

    let csv = std::fs::read_to_string(out.join("metrics.csv")).unwrap();
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let columns: BTreeSet<String> = header.iter().map(|s| s.to_string()).collect();
    assert_eq!(
        columns,
        documented("`metrics.csv`"),
        "metrics.csv vs METRICS.md"
    );
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    assert_eq!(
        rows.len() as f64,
        num(&m, "/estimate/poses"),
        "a row per estimate"
    );
    assert!(rows.iter().all(|r| r.len() == header.len()));
    // The CSV's errors are the ones behind the ATE.
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let errors: Vec<f64> = rows
        .iter()
        .map(|r| r[col("position_error_m")].parse().unwrap())
        .collect();
    let rmse = (errors.iter().map(|e| e * e).sum::<f64>() / errors.len() as f64).sqrt();
    assert!((rmse - num(&m, "/estimate/ate_rmse_m")).abs() < 1e-9);
    // Every step has its status and, with lossless delivery, its latency.
    assert!(rows.iter().all(|r| !r[col("n_eff")].is_empty()));
    assert!(rows.iter().all(|r| !r[col("latency_ms")].is_empty()));
}

#[test]
fn health_and_cost_come_from_the_status_topic_and_proc() {
    let m = metrics(run_folder());
    let steps = num(&m, "/filter/steps");
    assert_eq!(
        steps,
        num(&m, "/estimate/poses"),
        "a status per estimate: {m}"
    );
    let particles = num(&m, "/filter/particles");
    assert!(num(&m, "/filter/n_eff_min") <= num(&m, "/filter/n_eff_mean"));
    assert!(num(&m, "/filter/n_eff_mean") <= particles);
    assert!(num(&m, "/filter/resamplings") > 0.0, "{m}");
    assert_eq!(num(&m, "/cost/latency_ms/samples"), steps);
    assert!(num(&m, "/cost/latency_ms/median") <= num(&m, "/cost/latency_ms/p99"));
    let names: BTreeSet<&str> = m["cost"]["processes"]
        .as_array()
        .unwrap()
        .iter()
        .filter_map(|p| p["name"].as_str())
        .collect();
    let expected = [
        "client",
        "fastslam-service",
        "lidar-sim",
        "odometry-sim",
        "truth-sim",
    ];
    assert_eq!(names, expected.into_iter().collect(), "{m}");
    assert!(
        num(&m, "/cost/service_cpu_s") > 0.0,
        "the filter took CPU time: {m}"
    );
    for p in m["cost"]["processes"].as_array().unwrap() {
        assert!(num(p, "/peak_rss_mib") > 1.0, "{p}");
    }
}

#[test]
fn the_smoothing_back_end_is_received_scored_and_written() {
    let out = run_folder();
    let m = metrics(out);
    // bailey-short runs the back-end: at least the end-of-stream solve, over every scan
    // with sightings (as the reference), with the same landmarks.
    assert!(num(&m, "/smoothed/solves") >= 1.0, "{m}");
    let poses = num(&m, "/smoothed/poses");
    assert_eq!(poses, num(&m, "/reference/poses"), "{m}");
    let tum = std::fs::read_to_string(out.join("smoothed.tum")).unwrap();
    let rows = tum.lines().filter(|l| !l.starts_with('#')).count();
    assert_eq!(rows as f64, poses);
    let mapped = std::fs::read_to_string(out.join("smoothed_map.csv")).unwrap();
    assert_eq!(
        mapped.lines().count() as f64 - 1.0,
        num(&m, "/smoothed/map/estimated")
    );
    assert_eq!(num(&m, "/smoothed/map/spurious"), 0.0, "{m}");
    // With known association the back-end solves the reference's problem (with a robust
    // kernel): it lands next to it, and its χ² fits the noise.
    let (smoothed, reference) = (
        num(&m, "/smoothed/ate_rmse_m"),
        num(&m, "/reference/ate_rmse_m"),
    );
    assert!(smoothed < 1.3 * reference, "{smoothed} vs {reference}");
    assert!(
        (0.7..1.4).contains(&num(&m, "/smoothed/chi2_per_dof")),
        "{m}"
    );
}
