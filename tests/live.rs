//! The live view (`run --live`): a WebSocket client speaking Foxglove's protocol
//! (subprotocol `foxglove.sdk.v1`, with the Python `websockets` package) subscribes to
//! what the viewer advertises and receives poses and a map while the stack runs; and the
//! viewer changes nothing in a run's results.

mod common;

use common::*;
use std::net::TcpListener;
use std::path::Path;
use std::process::{Command, Stdio};

/// The WebSocket client release the test speaks Foxglove's protocol with.
const WEBSOCKETS: &str = "websockets==15.0.1";

/// A Foxglove WebSocket client: connects to `argv[1]` (retrying until the server is up),
/// subscribes to every channel the server advertises, and counts the message-data frames
/// (binary, opcode 1: subscription id u32, log time u64, payload) per topic until it has a
/// message of every topic `argv[3]` lists (comma-separated), the server closes, or
/// `argv[2]` seconds pass. A subscription the server
/// refuses as an unknown channel is sent again: the Foxglove SDK records an advertised
/// channel only after queueing its advertisement, so a fast client can beat it. Prints the
/// server's name, the advertised channels (topic → `schemaName/encoding`), the counts and
/// the largest payload per topic, and the topics whose subscription was refused, as JSON.
const CLIENT: &str = r#"import json, struct, sys, time
from websockets.sync.client import connect
from websockets.exceptions import ConnectionClosed
url, deadline = sys.argv[1], time.time() + float(sys.argv[2])
while True:
    try:
        ws = connect(url, subprotocols=['foxglove.sdk.v1'], open_timeout=5, max_size=None)
        break
    except OSError:
        if time.time() > deadline:
            raise
        time.sleep(0.2)
server, channels, by_sub, counts, sizes, refused = None, {}, {}, {}, {}, []
def subscribe(channel_ids):
    subscriptions = []
    for channel in channel_ids:
        sub = len(by_sub) + 1
        by_sub[sub] = channels[channel]['topic']
        subscriptions.append({'id': sub, 'channelId': channel})
    ws.send(json.dumps({'op': 'subscribe', 'subscriptions': subscriptions}))
with ws:
    assert ws.subprotocol == 'foxglove.sdk.v1', ws.subprotocol
    while time.time() < deadline and not all(counts.get(t) for t in sys.argv[3].split(',')):
        try:
            frame = ws.recv(timeout=1)
        except TimeoutError:
            continue
        except ConnectionClosed:
            break
        if isinstance(frame, str):
            op = json.loads(frame)
            if op['op'] == 'serverInfo':
                server = op['name']
            elif op['op'] == 'advertise':
                for c in op['channels']:
                    channels[c['id']] = c
                subscribe([c['id'] for c in op['channels']])
            elif op['op'] == 'status' and op['message'].startswith('Unknown channel ID: '):
                channel = int(op['message'].rsplit(' ', 1)[1])
                refused.append(channels[channel]['topic'])
                time.sleep(0.1)
                subscribe([channel])
        elif frame[0] == 1:
            sub, _log_time = struct.unpack_from('<IQ', frame, 1)
            topic = by_sub[sub]
            counts[topic] = counts.get(topic, 0) + 1
            sizes[topic] = max(sizes.get(topic, 0), len(frame) - 13)
advertised = {c['topic']: f"{c.get('schemaName', '')}/{c['encoding']}" for c in channels.values()}
print(json.dumps({'server': server, 'advertised': advertised, 'counts': counts, 'sizes': sizes,
                  'refused': refused}))
"#;

/// A TCP port nobody listens on right now.
fn free_port() -> u16 {
    let listener = TcpListener::bind("127.0.0.1:0").expect("binding a free port");
    listener.local_addr().unwrap().port()
}

/// Starts the launcher with `command` (`run …` or `replay …`) and `--live` on a free
/// port into `out`, connects the WebSocket client while it runs until it has a message of
/// each of `topics` (or the run ends), and checks that both succeeded; what the client
/// saw (its JSON).
fn watched(prefix: &str, out: &Path, command: &[String], topics: &[&str]) -> serde_json::Value {
    let python = python_venv("websockets-15.0.1", WEBSOCKETS)
        .join("bin")
        .join("python3");
    let port = free_port().to_string();
    let launcher = Command::new(LAUNCHER)
        .args(command)
        .args(["--prefix", prefix, "--timeout-s", "300"])
        .args(["--live", "--live-port", &port, "--out"])
        .arg(out)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("starting the launcher");
    let client = Command::new(python)
        .args(["-c", CLIENT, &format!("ws://127.0.0.1:{port}"), "60"])
        .arg(topics.join(","))
        .output()
        .expect("running the WebSocket client");
    let result = launcher
        .wait_with_output()
        .expect("waiting for the launcher");
    assert_success(&result);
    assert!(
        client.status.success(),
        "the WebSocket client failed: {}",
        String::from_utf8_lossy(&client.stderr)
    );
    serde_json::from_slice(&client.stdout).expect("the client prints JSON")
}

/// Checks that `seen` holds Foxglove's schemas for the stack's channels, at least one
/// pose and a map with landmarks in it, and that the run in `out` is complete with the
/// viewer's log beside the others.
fn assert_poses_and_a_map(seen: &serde_json::Value, out: &Path) {
    assert_eq!(seen["server"], "fastslam", "{seen}");
    let advertised = |topic: &str| seen["advertised"][topic].as_str().unwrap_or("").to_string();
    assert_eq!(advertised("/pose"), "foxglove.Odometry/protobuf", "{seen}");
    assert_eq!(
        advertised("/map"),
        "foxglove.SceneUpdate/protobuf",
        "{seen}"
    );
    for topic in ["/truth", "/dead_reckoning"] {
        assert_eq!(advertised(topic), "foxglove.PoseInFrame/protobuf", "{seen}");
    }
    assert_eq!(advertised("/trajectory"), "foxglove.PosesInFrame/protobuf");
    let count = |topic: &str| seen["counts"][topic].as_u64().unwrap_or(0);
    assert!(count("/pose") >= 1, "no pose received: {seen}");
    assert!(count("/map") >= 1, "no map received: {seen}");
    // A map message with landmarks: each landmark adds a sphere (tens of bytes) to the
    // scene entity.
    let map_bytes = seen["sizes"]["/map"].as_u64().unwrap_or(0);
    assert!(map_bytes > 200, "an empty map: {seen}");
    // The run itself is complete and the viewer left with the stack.
    assert_eq!(metrics(out)["complete"], true);
    assert!(out.join("logs").join("viewer.log").is_file());
}

/// Runs `command` (given the test's folder) with `--live` under a fresh prefix named
/// after `name`, and checks what a Foxglove client waiting for `topics` saw
/// ([`assert_poses_and_a_map`]), then `also` on what it saw and the run folder.
fn serves_poses_and_a_map(
    name: &str,
    topics: &[&str],
    command: impl FnOnce(&Path) -> Vec<String>,
    also: impl FnOnce(&serde_json::Value, &Path),
) {
    let prefix = prefix(name);
    let dir = folder(&prefix);
    let out = dir.join("run");
    let seen = watched(&prefix, &out, &command(&dir), topics);
    assert_poses_and_a_map(&seen, &out);
    also(&seen, &out);
    assert_no_leftovers_and_remove(&prefix, &dir);
}

#[test]
fn foxglove_receives_poses_the_map_and_the_particle_cloud_while_the_stack_runs() {
    let command = |dir: &Path| {
        // A real-time drive of about 12 s: time for a client to connect and see the map
        // grow; the service sends its particle cloud after every step.
        let path = short_scenario(dir);
        let text = std::fs::read_to_string(&path).unwrap();
        std::fs::write(&path, text + "\n[service.output]\nparticles_every = 1\n").unwrap();
        let scenario = path.display().to_string();
        ["run", "--realtime", "--scenario", &scenario]
            .map(String::from)
            .to_vec()
    };
    let particles = |seen: &serde_json::Value, out: &Path| {
        assert_eq!(
            seen["advertised"]["/particles"], "foxglove.PosesInFrame/protobuf",
            "{seen}"
        );
        assert!(
            seen["counts"]["/particles"].as_u64().unwrap_or(0) >= 1,
            "{seen}"
        );
        // One pose per particle (the scenario's 100), each some tens of bytes.
        assert!(
            seen["sizes"]["/particles"].as_u64().unwrap_or(0) > 100 * 40,
            "{seen}"
        );
        // The run folder's recording holds a cloud per pose estimate.
        let mcap = read_mcap(&out.join("run.mcap"));
        let count = |topic: &str| mcap["counts"][topic].as_u64().unwrap_or(0);
        assert!(count("/pose") > 10, "{mcap}");
        assert_eq!(count("/particles"), count("/pose"), "{mcap}");
        assert_eq!(
            mcap["schemas"]["/particles"],
            "foxglove.PosesInFrame/protobuf"
        );
    };
    serves_poses_and_a_map(
        "live_view",
        &["/pose", "/map", "/particles"],
        command,
        particles,
    );
}

#[test]
fn foxglove_receives_poses_and_the_map_while_a_recording_is_replayed() {
    serves_poses_and_a_map(
        "live_replay",
        &["/pose", "/map"],
        |dir| {
            // The first 60 s of MRCLAM robot 1, played at five times its pace: some 12 s.
            let data = mrclam_clip(&dir.join("data"), |t| t < 60.0, |_| true);
            let data = data.display().to_string();
            [
                "replay",
                "mrclam",
                "--data",
                &data,
                "--realtime",
                "--rate",
                "5",
            ]
            .map(String::from)
            .to_vec()
        },
        |_, _| {},
    );
}

#[test]
fn the_live_view_changes_no_result() {
    let prefix = prefix("live_same");
    let dir = folder(&prefix);
    let scenario = ["--scenario", "bailey-short"];
    let off = dir.join("off");
    assert_success(&run_stack(&prefix, &off, &scenario));
    let on = dir.join("on");
    let live = [&scenario[..], &["--live", "--live-port", "0"]].concat();
    assert_success(&run_stack(&prefix, &on, &live));
    assert_eq!(reproducible(&on), reproducible(&off));
    assert_no_leftovers_and_remove(&prefix, &dir);
}
