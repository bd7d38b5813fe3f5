//! Helpers for the integration tests: start the real launcher (which starts the real
//! processes over real iceoryx2), each test under its own stack prefix and folder, and
//! check what a run left behind.

#![allow(dead_code)] // each test binary uses a different subset

pub mod stacks;

pub use fastslam_protocol::ipc::remove_stack_files;
use fastslam_protocol::ipc::shared_memory_files;
use fastslam_sensors_sim::Scenario;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::{Duration, Instant};

/// The launcher binary cargo built for these tests.
pub const LAUNCHER: &str = env!("CARGO_BIN_EXE_fastslam-stack");

/// A stack prefix no other test (or test run) uses: test name, process id.
pub fn prefix(test: &str) -> String {
    let tag: String = test
        .chars()
        .filter(|c| c.is_ascii_alphanumeric())
        .take(12)
        .collect();
    format!("t{}{tag}x", std::process::id())
}

/// A fresh folder for a test's run folders. Folders of test processes that have ended
/// and that are more than an hour old are removed first: a failed run's stay for a look,
/// and the disk does not fill with every run's (a run of the suite writes about a
/// gigabyte).
pub fn folder(prefix: &str) -> PathBuf {
    let root = std::env::temp_dir().join("fastslam-tests");
    remove_ended(&root);
    let dir = root.join(prefix);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("creating the test folder");
    dir
}

/// Removes the folders under `root` last changed over an hour ago whose [`prefix`] names
/// a process that no longer runs.
fn remove_ended(root: &Path) {
    let hour = Duration::from_secs(3600);
    let Ok(entries) = std::fs::read_dir(root) else {
        return;
    };
    for entry in entries.flatten() {
        let name = entry.file_name().to_string_lossy().into_owned();
        let Some(rest) = name.strip_prefix('t') else {
            continue;
        };
        let digits: String = rest.chars().take_while(char::is_ascii_digit).collect();
        let Ok(pid) = digits.parse::<u32>() else {
            continue;
        };
        let alive = Path::new("/proc").join(pid.to_string()).exists();
        let old = (entry.metadata().and_then(|m| m.modified()))
            .is_ok_and(|t| t.elapsed().is_ok_and(|age| age > hour));
        if pid != std::process::id() && !alive && old {
            let _ = std::fs::remove_dir_all(entry.path());
        }
    }
}

/// Runs `fastslam-stack run` under `prefix`, writing the run folder `out`, with `extra`
/// flags; fails the test after a generous timeout instead of hanging.
pub fn run_stack(prefix: &str, out: &Path, extra: &[&str]) -> Output {
    Command::new(LAUNCHER)
        .args(["run", "--prefix", prefix, "--out"])
        .arg(out)
        .args(["--timeout-s", "600"])
        .args(extra)
        .output()
        .expect("starting the launcher")
}

/// The stack prefix the launcher's `test` announced on its stderr.
pub fn announced_prefix(out: &Output) -> String {
    let stderr = String::from_utf8_lossy(&out.stderr);
    stderr
        .split("FASTSLAM_PREFIX=")
        .nth(1)
        .and_then(|rest| rest.split_whitespace().next())
        .unwrap_or_else(|| panic!("no prefix announced: {stderr}"))
        .to_string()
}

/// The run folder's metrics.
pub fn metrics(out: &Path) -> serde_json::Value {
    let path = out.join("metrics.json");
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    serde_json::from_str(&text).expect("metrics.json is JSON")
}

/// The reproducible part of a run's metrics (see [`drop_timings`]).
pub fn reproducible(out: &Path) -> serde_json::Value {
    let mut m = metrics(out);
    drop_timings(&mut m);
    m
}

/// Removes what measures time on the machine from metrics: `cost` (which must be there)
/// and the reference's `solve_s`.
pub fn drop_timings(metrics: &mut serde_json::Value) {
    let sections = metrics.as_object_mut().expect("metrics.json is an object");
    sections
        .remove("cost")
        .expect("metrics.json has a cost section");
    if let Some(reference) = sections
        .get_mut("reference")
        .and_then(|r| r.as_object_mut())
    {
        reference.remove("solve_s");
    }
}

/// A number in the metrics, by JSON pointer.
pub fn num(m: &serde_json::Value, pointer: &str) -> f64 {
    m.pointer(pointer)
        .and_then(serde_json::Value::as_f64)
        .unwrap_or_else(|| panic!("no number at {pointer} in {m}"))
}

/// Processes whose command line mentions `prefix`, and shared-memory files named after it.
pub fn leftovers(prefix: &str) -> (Vec<String>, Vec<String>) {
    let processes = std::fs::read_dir("/proc")
        .into_iter()
        .flatten()
        .flatten()
        .filter_map(|e| {
            let cmdline = std::fs::read(e.path().join("cmdline")).ok()?;
            let text = String::from_utf8_lossy(&cmdline).replace('\0', " ");
            text.contains(prefix)
                .then(|| format!("{}: {text}", e.file_name().to_string_lossy()))
        })
        .collect();
    let files = shared_memory_files(prefix)
        .iter()
        .filter_map(|path| Some(path.file_name()?.to_string_lossy().into_owned()))
        .collect();
    (processes, files)
}

/// Fails the test if a process or a shared-memory file of stack `prefix` is left.
pub fn assert_no_leftovers(prefix: &str) {
    assert_eq!(
        leftovers(prefix),
        (vec![], vec![]),
        "processes or shared memory left behind"
    );
}

/// [`assert_no_leftovers`], then removes the test's folder `dir` (kept when it fails).
pub fn assert_no_leftovers_and_remove(prefix: &str, dir: &Path) {
    assert_no_leftovers(prefix);
    std::fs::remove_dir_all(dir).ok();
}

/// Fails the test with the launcher's output unless it exited 0.
pub fn assert_success(out: &Output) {
    assert_exited_ok("launcher", out);
}

/// Fails the test with `out` unless the command `what` names exited 0.
pub fn assert_exited_ok(what: &str, out: &Output) {
    assert!(
        out.status.success(),
        "{what} failed ({}):\nstdout:\n{}\nstderr:\n{}",
        out.status,
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}

/// The iceoryx2 wheels the Python tests use: the 0.10 line, wire-compatible with the
/// stack's iceoryx2.
pub const ICEORYX2_WHEEL: &str = "iceoryx2>=0.10,<0.11";

/// The evo release the run-folder test checks our ATE against.
pub const EVO: &str = "evo==1.38.1";

/// The MCAP reader release the run-folder tests read `run.mcap` with.
pub const MCAP: &str = "mcap==1.6.0";

/// What the Python `mcap` package (see [`python_venv`]) reads in the MCAP file `path`:
/// per channel of its summary, the messages counted on it, its schema (`name/encoding`,
/// empty for none) and its message encoding (`{"counts": {…}, "schemas": {…},
/// "encodings": {…}}`), and the JSON message on `/metrics`, parsed (`"metrics"`). A file
/// without summary (closed after its writer was killed) is read from the start: its
/// channels are those its messages name.
pub fn read_mcap(path: &Path) -> serde_json::Value {
    const READER: &str = "import json, sys
from mcap.reader import make_reader
counts, schemas, encodings, metrics = {}, {}, {}, None
with open(sys.argv[1], 'rb') as f:
    reader = make_reader(f)
    summary = reader.get_summary()
    def see(schema, channel):
        counts.setdefault(channel.topic, 0)
        schemas[channel.topic] = f'{schema.name}/{schema.encoding}' if schema else ''
        encodings[channel.topic] = channel.message_encoding
    for channel in summary.channels.values() if summary else []:
        see(summary.schemas.get(channel.schema_id), channel)
    for schema, channel, message in reader.iter_messages():
        see(schema, channel)
        counts[channel.topic] += 1
        if channel.topic == '/metrics':
            metrics = json.loads(message.data)
print(json.dumps({'counts': counts, 'schemas': schemas, 'encodings': encodings, 'metrics': metrics}))
";
    let python = python_venv("mcap-1.6.0", MCAP).join("bin").join("python3");
    let what = format!("the mcap reader on {}", path.display());
    let out = run_ok(&what, Command::new(python).args(["-c", READER]).arg(path));
    serde_json::from_slice(&out.stdout).expect("the reader prints JSON")
}

/// A Python interpreter with the iceoryx2 wheel (see [`python_venv`]).
pub fn python_with_iceoryx2() -> PathBuf {
    python_venv("iceoryx2-0.10", ICEORYX2_WHEEL)
        .join("bin")
        .join("python3")
}

/// `evo_ape` from PyPI (see [`python_venv`]), or `$EVO_APE` when set.
pub fn evo_ape() -> PathBuf {
    match std::env::var_os("EVO_APE") {
        Some(p) => PathBuf::from(p),
        None => python_venv("evo-1.38.1", EVO).join("bin").join("evo_ape"),
    }
}

/// A Python virtual environment named `name` with `requirement` installed from PyPI,
/// under the cargo target directory: created on first use (`python3 -m venv`, then
/// `pip install`) and reused afterwards, so the README's test command works on a fresh
/// machine with Python and access to PyPI. Tests running in parallel serialise on a lock
/// file; the environment is built in place (a venv's scripts name its own path, so it
/// cannot be moved) and marked done only once complete.
///
/// # Panics
/// With the reason when Python, venv or pip fail (a test that needs Python must not pass
/// without it).
pub fn python_venv(name: &str, requirement: &str) -> PathBuf {
    let target = Path::new(LAUNCHER)
        .parent()
        .and_then(Path::parent)
        .expect("the launcher lives in <target>/<profile>/");
    let home = target.join("python");
    std::fs::create_dir_all(&home).expect("creating the Python folder in the target dir");
    let venv = home.join(format!("venv-{name}"));
    let done = venv.join(".installed");
    let lock = std::fs::File::create(home.join(format!("venv-{name}.lock")))
        .expect("creating the venv lock file");
    lock.lock().expect("locking the venv");
    if done.is_file() {
        return venv;
    }
    let _ = std::fs::remove_dir_all(&venv); // a build that did not finish
    let step = |what: &str, cmd: &mut Command| {
        run_ok(&format!("Python bootstrap: {what}"), cmd);
    };
    step(
        "python3 -m venv",
        Command::new("python3").args(["-m", "venv"]).arg(&venv),
    );
    step(
        &format!("pip install {requirement}"),
        Command::new(venv.join("bin").join("python3"))
            .args([
                "-m",
                "pip",
                "install",
                "--quiet",
                "--disable-pip-version-check",
            ])
            .arg(requirement),
    );
    std::fs::write(&done, requirement).expect("marking the venv done");
    venv
}

/// The stack's processes running now, the launcher included: process id and subcommand
/// (`run`, `service`, `lidar-sim`, …) of each process whose arguments hold `prefix`.
pub fn stack_processes(prefix: &str) -> Vec<(i32, String)> {
    let Ok(proc) = std::fs::read_dir("/proc") else {
        return Vec::new();
    };
    proc.flatten()
        .filter_map(|e| {
            let pid = e.file_name().to_string_lossy().parse().ok()?;
            let cmdline = std::fs::read(e.path().join("cmdline")).ok()?;
            let args: Vec<&[u8]> = cmdline.split(|&b| b == 0).collect();
            let subcommand = String::from_utf8_lossy(args.get(1)?).into_owned();
            args.contains(&prefix.as_bytes())
                .then_some((pid, subcommand))
        })
        .collect()
}

/// Process id of the stack's service, once it runs.
pub fn service_pid(prefix: &str) -> Option<i32> {
    stack_processes(prefix)
        .into_iter()
        .find_map(|(pid, subcommand)| (subcommand == "service").then_some(pid))
}

/// Polls `ready` every 10 ms for up to `limit`, failing the test with `what`.
pub fn wait_for(what: &str, limit: Duration, mut ready: impl FnMut() -> bool) {
    let start = Instant::now();
    while !ready() {
        assert!(start.elapsed() < limit, "timed out waiting for {what}");
        std::thread::sleep(Duration::from_millis(10));
    }
}

/// Sends SIGTERM to the stack's service and waits for the launcher: a service stopped on
/// purpose finishes cleanly, so the launcher must exit 0 (its stderr otherwise).
pub fn stop_service_and_wait(prefix: &str, launcher: std::process::Child) {
    let pid = service_pid(prefix).expect("the service is running");
    nix::sys::signal::kill(
        nix::unistd::Pid::from_raw(pid),
        nix::sys::signal::Signal::SIGTERM,
    )
    .unwrap();
    let out = launcher.wait_with_output().unwrap();
    assert_eq!(
        out.status.code(),
        Some(0),
        "the service stopped cleanly and the stack finished: {}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// The processes of one stack started one by one with the launcher's hidden subcommands
/// (as `run` starts them), so a test can kill and restart one. Process `name`'s n-th
/// start logs to `<dir>/<name>.<n>.log`. On drop, whatever still runs gets SIGTERM, then
/// SIGKILL, and the stack's iceoryx2 files are removed.
pub struct HandStack {
    /// The stack's prefix.
    pub prefix: String,
    /// The stack's iceoryx2 root, as `fastslam-stack run` derives it from the prefix.
    pub root: PathBuf,
    /// Where the logs go.
    pub dir: PathBuf,
    /// The processes started and not killed, oldest first.
    pub children: Vec<(&'static str, std::process::Child)>,
}

impl HandStack {
    /// A stack under `prefix` logging into `dir` (created).
    pub fn new(prefix: &str, dir: PathBuf) -> Self {
        std::fs::create_dir_all(&dir).expect("creating the log folder");
        Self {
            prefix: prefix.to_string(),
            root: fastslam_stack::stack_root(prefix),
            dir,
            children: Vec::new(),
        }
    }

    /// Starts `fastslam-stack <name> --prefix P --iox-root R <flags>`.
    pub fn start<S: AsRef<std::ffi::OsStr>>(&mut self, name: &'static str, flags: &[S]) {
        let n = std::fs::read_dir(&self.dir)
            .into_iter()
            .flatten()
            .flatten()
            .filter(|e| {
                e.file_name()
                    .to_string_lossy()
                    .starts_with(&format!("{name}."))
            })
            .count();
        let log = std::fs::File::create(self.dir.join(format!("{name}.{n}.log"))).unwrap();
        let child = Command::new(LAUNCHER)
            .args([name, "--prefix", &self.prefix, "--iox-root"])
            .arg(&self.root)
            .args(flags)
            .stdout(log.try_clone().unwrap())
            .stderr(log)
            .spawn()
            .unwrap();
        self.children.push((name, child));
    }

    /// Joins the stack as a process of the test's own, named `name`.
    pub fn join(&self, name: &str) -> fastslam_protocol::ipc::Ipc {
        let stack = fastslam_protocol::ipc::StackConfig {
            prefix: self.prefix.clone(),
            root: Some(self.root.display().to_string()),
        };
        fastslam_protocol::ipc::Ipc::open(&stack, name, Duration::from_secs(30)).unwrap()
    }

    /// The newest running process `name`.
    pub fn child(&mut self, name: &str) -> &mut std::process::Child {
        let (_, child) = (self.children.iter_mut().rev())
            .find(|(n, _)| *n == name)
            .expect("no such process");
        child
    }

    /// SIGKILLs the newest `name`, reaps it and forgets it.
    pub fn kill(&mut self, name: &str) {
        let i = (self.children.iter().rposition(|(n, _)| *n == name)).expect("no such process");
        let (_, mut child) = self.children.remove(i);
        child.kill().unwrap();
        child.wait().unwrap();
    }

    /// Waits up to `limit` for every process to exit (failing the test naming the ones
    /// still running); their exit statuses by name.
    pub fn wait_all(&mut self, limit: Duration) -> Vec<(&'static str, std::process::ExitStatus)> {
        let start = Instant::now();
        let mut statuses = Vec::new();
        for (name, child) in &mut self.children {
            loop {
                if let Some(status) = child.try_wait().unwrap() {
                    statuses.push((*name, status));
                    break;
                }
                assert!(
                    start.elapsed() < limit,
                    "{name} still running; logs in {}",
                    self.dir.display()
                );
                std::thread::sleep(Duration::from_millis(20));
            }
        }
        statuses
    }
}

impl Drop for HandStack {
    fn drop(&mut self) {
        for (_, child) in &mut self.children {
            if child.try_wait().ok().flatten().is_none() {
                let pid = nix::unistd::Pid::from_raw(child.id() as i32);
                let _ = nix::sys::signal::kill(pid, nix::sys::signal::Signal::SIGTERM);
                std::thread::sleep(Duration::from_millis(200));
                let _ = child.kill();
                let _ = child.wait();
            }
        }
        remove_stack_files(&self.prefix, Some(&self.root));
    }
}

/// The built-in scenario `name` with its route replaced by `waypoints` (a TOML array),
/// renamed `renamed`: a scenario file may not take the name of a built-in it differs from.
pub fn rerouted(name: &str, renamed: &str, waypoints: &str) -> String {
    let text = (fastslam_sensors_sim::scenario::BUILT_IN.iter())
        .find(|(n, _)| *n == name)
        .expect("a built-in scenario")
        .1;
    let start = text.find("waypoints = [").expect("a route");
    let end = start
        + text[start..]
            .find("\n]")
            .expect("the list ends on its own line")
        + 2;
    format!("{}waypoints = {waypoints}{}", &text[..start], &text[end..]).replace(
        &format!("name = \"{name}\""),
        &format!("name = \"{renamed}\""),
    )
}

/// The occupied cells of a run folder's map (`map.yaml` + `map.pgm`, map_server format),
/// as cell-centre coordinates (m), and the resolution.
pub fn occupied_cells(out: &Path) -> (Vec<[f64; 2]>, f64) {
    let yaml = std::fs::read_to_string(out.join("map.yaml")).expect("map.yaml");
    let value = |key: &str| -> String {
        let line = yaml.lines().find(|l| l.starts_with(key)).unwrap();
        line[key.len()..].trim().to_string()
    };
    let resolution: f64 = value("resolution:").parse().unwrap();
    let origin: Vec<f64> = value("origin:")
        .trim_matches(['[', ']'])
        .split(',')
        .map(|v| v.trim().parse().unwrap())
        .collect();
    let pgm = std::fs::read(out.join("map.pgm")).expect("map.pgm");
    let text = String::from_utf8_lossy(&pgm[..20]).to_string();
    let mut fields = text.split_whitespace();
    assert_eq!(fields.next(), Some("P5"));
    let width: usize = fields.next().unwrap().parse().unwrap();
    let height: usize = fields.next().unwrap().parse().unwrap();
    let pixels = &pgm[pgm.len() - width * height..];
    let cells = pixels
        .iter()
        .enumerate()
        .filter(|(_, p)| **p == 0)
        .map(|(k, _)| {
            let (column, row) = (k % width, k / width);
            let j = height - 1 - row; // image row 0 is the top of the map
            [
                origin[0] + (column as f64 + 0.5) * resolution,
                origin[1] + (j as f64 + 0.5) * resolution,
            ]
        })
        .collect();
    (cells, resolution)
}

/// Precision and recall of a run folder's map against `scenario`'s walls and poles
/// ([`fastslam_sensors_sim::scenario::World::map_precision_recall`]), from the map files.
pub fn precision_recall(out: &Path, scenario: &Scenario, tolerance: f64) -> (f64, f64) {
    let (cells, resolution) = occupied_cells(out);
    assert!(
        cells.len() > 100,
        "an almost empty grid: {} cells",
        cells.len()
    );
    (scenario.world).map_precision_recall(&cells, resolution, tolerance)
}

/// A short real-time drive (the start of `bailey-short` at 6 m/s: about 12 s simulated),
/// written to `dir`.
pub fn short_scenario(dir: &Path) -> PathBuf {
    let text = rerouted(
        "bailey-short",
        "short-drive",
        "[[12.649533, -41.588785], [44.736760, -54.984424]]",
    )
    .replace("speed_mps = 3.0", "speed_mps = 6.0");
    let path = dir.join("short-drive.toml");
    std::fs::write(&path, text).unwrap();
    path
}

/// Scans a lidar published, from the count its log `lidar_log` ends with (the test fails
/// if the lidar did not finish its route). A launcher's run keeps it in
/// `<run>/logs/lidar-sim.log`.
pub fn scans_published(lidar_log: &Path) -> u64 {
    let log = std::fs::read_to_string(lidar_log).unwrap();
    log.split("finished messages=")
        .nth(1)
        .and_then(|rest| rest.split_whitespace().next()?.parse().ok())
        .unwrap_or_else(|| panic!("the lidar did not finish its route: {log}"))
}

/// Scans the service applied and how many of them it read straight from shared memory,
/// from the line its log `service_log` ends with. A launcher's run keeps it in
/// `<run>/logs/service.log`.
pub fn scans_from_shared_memory(service_log: &Path) -> (u64, u64) {
    let log = std::fs::read_to_string(service_log).unwrap();
    let count = |key: &str| -> u64 {
        log.rfind(key)
            .and_then(|at| {
                log[at + key.len()..]
                    .split_whitespace()
                    .next()?
                    .parse()
                    .ok()
            })
            .unwrap_or_else(|| panic!("no `{key}` in the service's log: {log}"))
    };
    (count(" scans="), count(" scans_from_shared_memory="))
}

/// Asserts that the service of the run in `out` read (nearly) every scan straight from
/// shared memory. A scan that waits for its odometry is held there; only one held past
/// the hold limit (a starved odometry sensor on a loaded machine) is copied, so a few
/// copies are allowed. Before scans were held, 6-25 % went direct as fast as possible.
pub fn assert_zero_copy(out: &Path) {
    let (scans, direct) = scans_from_shared_memory(&out.join("logs").join("service.log"));
    assert!(
        scans > 0 && direct as f64 >= 0.9 * scans as f64,
        "only {direct} of {scans} scans went to the filter straight from shared memory"
    );
}

/// The text of MRCLAM file `name` (plain or gzipped) in the repository's data set.
fn mrclam_file(name: &str) -> String {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("data/mrclam7");
    if let Ok(text) = std::fs::read_to_string(dir.join(name)) {
        return text;
    }
    let gz = std::fs::File::open(dir.join(format!("{name}.gz"))).unwrap();
    let mut text = String::new();
    std::io::Read::read_to_string(&mut flate2::read::GzDecoder::new(gz), &mut text).unwrap();
    text
}

/// The rows of `text` whose time (first column, seconds after `t0`) `keep` accepts,
/// comment lines included.
fn rows(text: &str, t0: f64, keep: impl Fn(f64) -> bool) -> String {
    let kept = text.lines().filter(|line| {
        let time = line
            .split_whitespace()
            .next()
            .and_then(|t| t.parse::<f64>().ok());
        time.is_none_or(|t| keep(t - t0))
    });
    kept.map(|l| format!("{l}\n")).collect()
}

/// MRCLAM robot 1 written as a data set in `data`: the records at the times (seconds
/// from its first odometry record) `within` accepts, and of the camera's only those
/// `seen` accepts too.
pub fn mrclam_clip(
    data: &Path,
    within: impl Fn(f64) -> bool,
    seen: impl Fn(f64) -> bool,
) -> PathBuf {
    std::fs::create_dir_all(data).unwrap();
    for name in ["Barcodes.dat", "Landmark_Groundtruth.dat"] {
        std::fs::write(data.join(name), mrclam_file(name)).unwrap();
    }
    let odometry = mrclam_file("Robot1_Odometry.dat");
    let t0 = odometry
        .lines()
        .find_map(|l| l.split_whitespace().next()?.parse::<f64>().ok())
        .expect("odometry records");
    let write = |name: &str, text: String| std::fs::write(data.join(name), text).unwrap();
    write("Robot1_Odometry.dat", rows(&odometry, t0, &within));
    write(
        "Robot1_Groundtruth.dat",
        rows(&mrclam_file("Robot1_Groundtruth.dat"), t0, &within),
    );
    write(
        "Robot1_Measurement.dat",
        rows(&mrclam_file("Robot1_Measurement.dat"), t0, |t| {
            within(t) && seen(t)
        }),
    );
    data.to_path_buf()
}

/// The `rosbags` release (PyPI) the tests write and convert bags with: an implementation
/// of the formats independent of the stack's reader.
pub const ROSBAGS: &str = "rosbags==0.11.9";

/// The `bin` folder of a virtual environment with [`ROSBAGS`] (`python3`,
/// `rosbags-convert`), built on first use ([`python_venv`]).
pub fn rosbags_bin() -> PathBuf {
    python_venv("rosbags-0.11.9", ROSBAGS).join("bin")
}

/// Converts the bag `source` into `target` with `rosbags-convert` (a ROS 1 `.bag` for a
/// target so named; `--compress compression`, then `more` flags), panicking with its
/// output when it fails.
pub fn rosbags_convert(source: &Path, target: &Path, compression: &str, more: &[&str]) {
    run_ok(
        &format!("rosbags-convert {}", source.display()),
        Command::new(rosbags_bin().join("rosbags-convert"))
            .arg("--src")
            .arg(source)
            .arg("--dst")
            .arg(target)
            .args(["--dst-typestore", "ros1_noetic", "--compress", compression])
            .args(more),
    );
}

/// Runs `cmd` (`what` names it) and returns its output, failing the test with that output
/// when it cannot start or fails.
pub fn run_ok(what: &str, cmd: &mut Command) -> Output {
    let out = cmd
        .output()
        .unwrap_or_else(|e| panic!("{what} could not start: {e}"));
    assert_exited_ok(what, &out);
    out
}
