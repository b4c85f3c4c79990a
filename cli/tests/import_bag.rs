//! `kincal import-bag`: bags written here with the `mcap` crate (and, where Python's `mcap`
//! package is installed, by `scripts/write_test_bag.py`, an independent writer with its own
//! CDR encoding) read back into rows that are checked against the poses the test knows.

use std::collections::BTreeMap;
use std::fs;
use std::path::Path;
use std::process::{Command, Output};

use kincal::aria;
use kincal::pose::matrix_to_quaternion;
use kincal_io::cdr::write as cdr;
use kincal_io::measurements::{Orientation, ReadOptions, read_measurements};

fn kincal(args: &[&str], dir: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_kincal"))
        .args(args)
        .current_dir(dir)
        .output()
        .expect("run kincal")
}

fn code(o: &Output) -> i32 {
    o.status.code().unwrap_or(-1)
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// One message to write: topic, schema name, log time [ns], CDR bytes.
struct Msg {
    topic: &'static str,
    schema: &'static str,
    log_ns: u64,
    data: Vec<u8>,
}

/// Writes the messages as an MCAP file (zstd-compressed chunks, the crate's default, as
/// rosbag2 writes by default) with ROS 2 schema and channel conventions.
fn write_bag(path: &Path, msgs: &[Msg]) {
    write_bag_with(path, msgs, mcap::WriteOptions::new());
}

/// [`write_bag`] with the writer's options (chunking, compression).
fn write_bag_with(path: &Path, msgs: &[Msg], options: mcap::WriteOptions) {
    let file = std::io::BufWriter::new(fs::File::create(path).unwrap());
    let mut w = options.create(file).unwrap();
    let mut channels: BTreeMap<&str, u16> = BTreeMap::new();
    for m in msgs {
        let id = match channels.get(m.topic) {
            Some(id) => *id,
            None => {
                let schema = w.add_schema(m.schema, "ros2msg", b"").unwrap();
                let id = w
                    .add_channel(schema, m.topic, "cdr", &BTreeMap::new())
                    .unwrap();
                channels.insert(m.topic, id);
                id
            }
        };
        let header = mcap::records::MessageHeader {
            channel_id: id,
            sequence: 0,
            log_time: m.log_ns,
            publish_time: m.log_ns,
        };
        w.write_to_known_channel(&header, &m.data).unwrap();
    }
    w.finish().unwrap();
}

const T0_NS: i128 = 1_700_000_000_000_000_000;
const JOINT_PERIOD_NS: i128 = 10_000_000; // 100 Hz
const POSE_PERIOD_NS: i128 = 8_333_333; // 120 Hz
const MOVE_NS: i128 = 1_000_000_000;
const STAND_NS: i128 = 2_000_000_000;

/// The poses the arm stands at (ARIA joint values [rad]); neighbours differ by >= 0.5 rad in
/// some joint, so a moving reading leaves --still-tol at once.
fn poses() -> Vec<[f64; 6]> {
    vec![
        [0.4813, 0.7750, -1.0383, 3.6605, 1.1053, -2.8499],
        [-0.3, 1.2, -0.6, 2.9, 0.4, -1.9],
        [0.9, 0.3, -1.4, 3.3, 1.6, -2.2],
        [0.1, 0.9, -0.9, 2.4, 0.8, -2.6],
    ]
}

/// Joint values at time `t` (from T0): each pose is approached in a linear move of
/// MOVE_NS from the previous one, then held for STAND_NS.
fn q_at(t_ns: i128) -> Option<[f64; 6]> {
    let ps = poses();
    let seg = MOVE_NS + STAND_NS;
    let k = usize::try_from(t_ns / seg).ok()?;
    let target = *ps.get(k)?;
    let from = if k == 0 { target } else { ps[k - 1] };
    let dt = t_ns % seg;
    if dt >= MOVE_NS {
        return Some(target);
    }
    let f = dt as f64 / MOVE_NS as f64;
    Some(std::array::from_fn(|j| from[j] + f * (target[j] - from[j])))
}

fn end_ns() -> i128 {
    (MOVE_NS + STAND_NS) * poses().len() as i128
}

/// The measured pose at time t: the nominal ARIA's FK plus a small deterministic position
/// wobble (so averaging is exercised), quaternion (w, x, y, z).
fn pose_at(t_ns: i128) -> Option<([f64; 3], [f64; 4])> {
    let q = q_at(t_ns)?;
    let tf = aria::nominal().fk_q(&q).unwrap();
    let phase = (t_ns / POSE_PERIOD_NS) as f64;
    let wobble = 2e-4 * (1.7 * phase).sin();
    let p = tf.translation.vector;
    let q = matrix_to_quaternion(tf.rotation.matrix());
    Some(([p.x + wobble, p.y - wobble, p.z + 0.5 * wobble], q))
}

const ARIA_NAMES: [&str; 6] = ["joint1", "joint2", "joint3", "joint4", "joint5", "joint6"];

/// A bag of the scenario: joint readings (names shuffled, a gripper joint added, and a
/// gripper-only publisher on the same topic) and poses on `pose_topic`.
fn scenario(pose_schema: &'static str) -> Vec<Msg> {
    let mut msgs = Vec::new();
    let order = [3usize, 0, 5, 1, 4, 2];
    let mut t = 0;
    while t < end_ns() {
        let q = q_at(t).unwrap();
        let mut names: Vec<&str> = order.iter().map(|&j| ARIA_NAMES[j]).collect();
        let mut pos: Vec<f64> = order.iter().map(|&j| q[j]).collect();
        names.push("gripper");
        pos.push(0.04);
        let stamp = T0_NS + t;
        // Received 1 ms after the stamp.
        let log = u64::try_from(stamp + 1_000_000).unwrap();
        msgs.push(Msg {
            topic: "/joint_states",
            schema: "sensor_msgs/msg/JointState",
            log_ns: log,
            data: cdr::joint_state(stamp, &names, &pos),
        });
        if (t / JOINT_PERIOD_NS) % 10 == 0 {
            msgs.push(Msg {
                topic: "/joint_states",
                schema: "sensor_msgs/msg/JointState",
                log_ns: log,
                data: cdr::joint_state(stamp, &["gripper_finger"], &[0.01]),
            });
        }
        t += JOINT_PERIOD_NS;
    }
    let mut t = 0;
    while t < end_ns() {
        let (p, quat) = pose_at(t).unwrap();
        let stamp = T0_NS + t;
        let log = u64::try_from(stamp + 2_000_000).unwrap();
        let data = if pose_schema.ends_with("TransformStamped") {
            cdr::transform_stamped(stamp, "mocap", "tool", p, quat)
        } else if pose_schema.ends_with("PointStamped") {
            cdr::point_stamped(stamp, "tracker", p)
        } else {
            cdr::pose_stamped(stamp, "mocap", p, quat)
        };
        msgs.push(Msg {
            topic: "/tool",
            schema: pose_schema,
            log_ns: log,
            data,
        });
        t += POSE_PERIOD_NS;
    }
    // The recorder writes in arrival order.
    msgs.sort_by_key(|m| m.log_ns);
    msgs
}

/// What the rows must be, computed here from the scenario's own definition: for pose k,
/// the joint readings equal to it and the measurements stamped between the first and the
/// last of them.
fn expected_rows() -> Vec<([f64; 6], [f64; 3], [f64; 4])> {
    poses()
        .iter()
        .map(|pk| {
            let times: Vec<i128> = (0..end_ns() / JOINT_PERIOD_NS)
                .map(|i| i * JOINT_PERIOD_NS)
                .filter(|&t| q_at(t).unwrap() == *pk)
                .collect();
            let (first, last) = (times[0], *times.last().unwrap());
            let picked: Vec<[f64; 3]> = (0..=end_ns() / POSE_PERIOD_NS)
                .map(|i| i * POSE_PERIOD_NS)
                .filter(|&t| t >= first && t <= last)
                .map(|t| pose_at(t).unwrap().0)
                .collect();
            let n = picked.len() as f64;
            let mean = std::array::from_fn(|a| picked.iter().map(|p| p[a]).sum::<f64>() / n);
            let tf = aria::nominal().fk_q(pk).unwrap();
            (*pk, mean, matrix_to_quaternion(tf.rotation.matrix()))
        })
        .collect()
}

fn read_rows(path: &Path) -> kincal_io::measurements::MeasurementSet {
    read_measurements(path, &ReadOptions::new(6)).unwrap()
}

fn check_rows(csv: &Path, with_orientation: bool) {
    let set = read_rows(csv);
    let want = expected_rows();
    assert_eq!(set.rows.len(), want.len(), "one row per standstill");
    for (k, (row, (q, p, quat))) in set.rows.iter().zip(&want).enumerate() {
        assert_eq!(row.pose_id.as_deref(), Some((k + 1).to_string().as_str()));
        for (a, b) in row.q_rad.iter().zip(q) {
            assert!((a - b).abs() < 1e-12, "row {k}: q {a} vs {b}");
        }
        let pos = row.position_m.unwrap();
        for (a, b) in pos.iter().zip(p) {
            assert!((a - b).abs() < 1e-12, "row {k}: position {a} vs {b}");
        }
        match (row.orientation, with_orientation) {
            (Some(Orientation::Quaternion { w, x, y, z }), true) => {
                let dot = (w * quat[0] + x * quat[1] + y * quat[2] + z * quat[3]).abs();
                assert!((1.0 - dot) < 1e-12, "row {k}: orientation off, |dot| {dot}");
            }
            (None, false) => {}
            (o, _) => panic!("row {k}: unexpected orientation {o:?}"),
        }
    }
}

#[test]
fn pose_stamped_by_name_gives_one_row_per_standstill_at_the_known_poses() {
    let dir = tempfile::tempdir().unwrap();
    write_bag(
        &dir.path().join("b.mcap"),
        &scenario("geometry_msgs/msg/PoseStamped"),
    );
    let o = kincal(
        &[
            "import-bag",
            "b.mcap",
            "--joints",
            "/joint_states",
            "--pose",
            "/tool",
            "--robot",
            "aria",
            "--out",
            "d.csv",
        ],
        dir.path(),
    );
    assert_eq!(code(&o), 0, "{}", stderr(&o));
    let err = stderr(&o);
    assert!(err.contains("-> 4 rows"), "{err}");
    assert!(err.contains("while the arm moved"), "{err}");
    assert!(err.contains("without any of the robot's joints"), "{err}");
    assert!(
        err.contains("ignored joints not in the robot: gripper"),
        "{err}"
    );
    check_rows(&dir.path().join("d.csv"), true);
    let text = fs::read_to_string(dir.path().join("d.csv")).unwrap();
    assert!(text.contains("# robot: aria"), "{text}");
    assert!(text.contains("in frame 'mocap'"), "{text}");
}

#[test]
fn transform_stamped_by_order_on_the_receive_clock() {
    let dir = tempfile::tempdir().unwrap();
    // By order needs one publisher with the robot's joints only.
    let msgs: Vec<Msg> = scenario("geometry_msgs/msg/TransformStamped")
        .into_iter()
        .filter_map(|m| {
            if m.topic != "/joint_states" {
                return Some(m);
            }
            let js = kincal_io::cdr::joint_state(&m.data).unwrap();
            if js.name.len() != 7 {
                return None;
            }
            let mut q = [0.0; 6];
            for (n, v) in js.name.iter().zip(&js.position) {
                if let Some(j) = ARIA_NAMES.iter().position(|a| a == n) {
                    q[j] = *v;
                }
            }
            let data = cdr::joint_state(js.header.stamp_ns, &[], &q);
            Some(Msg { data, ..m })
        })
        .collect();
    write_bag(&dir.path().join("b.mcap"), &msgs);
    let o = kincal(
        &[
            "import-bag",
            "b.mcap",
            "--joints",
            "/joint_states",
            "--pose",
            "/tool",
            "--clock",
            "receive",
            "--out",
            "d.csv",
        ],
        dir.path(),
    );
    assert_eq!(code(&o), 0, "{}", stderr(&o));
    // On the receive clock the joints lag 1 ms and the poses 2 ms: the same readings pair up
    // except at the standstills' edges, so the rows are the poses; positions are compared
    // loosely (the edge measurements may differ by one).
    let set = read_rows(&dir.path().join("d.csv"));
    let want = expected_rows();
    assert_eq!(set.rows.len(), 4);
    for (row, (q, p, _)) in set.rows.iter().zip(&want) {
        for (a, b) in row.q_rad.iter().zip(q) {
            assert!((a - b).abs() < 1e-12);
        }
        for (a, b) in row.position_m.unwrap().iter().zip(p) {
            assert!((a - b).abs() < 2e-5, "{a} vs {b}");
        }
    }
}

#[test]
fn point_stamped_gives_positions_only() {
    let dir = tempfile::tempdir().unwrap();
    write_bag(
        &dir.path().join("b.mcap"),
        &scenario("geometry_msgs/msg/PointStamped"),
    );
    let o = kincal(
        &[
            "import-bag",
            "b.mcap",
            "--joints",
            "/joint_states",
            "--point",
            "/tool",
            "--robot",
            "aria",
            "--out",
            "d.csv",
        ],
        dir.path(),
    );
    assert_eq!(code(&o), 0, "{}", stderr(&o));
    check_rows(&dir.path().join("d.csv"), false);
}

#[test]
fn thresholds_decide_what_is_a_standstill() {
    let dir = tempfile::tempdir().unwrap();
    write_bag(
        &dir.path().join("b.mcap"),
        &scenario("geometry_msgs/msg/PoseStamped"),
    );
    // Standstills last 2 s (the first one 3 s): asking for 3.5 s leaves none (exit 3, with
    // the counts).
    let o = kincal(
        &[
            "import-bag",
            "b.mcap",
            "--joints",
            "/joint_states",
            "--pose",
            "/tool",
            "--robot",
            "aria",
            "--min-still-s",
            "3.5",
            "--out",
            "d.csv",
        ],
        dir.path(),
    );
    assert_eq!(code(&o), 3, "{}", stderr(&o));
    assert!(stderr(&o).contains("0 standstills"), "{}", stderr(&o));
    assert!(!dir.path().join("d.csv").exists());
    // The wobble is 0.2 mm: a 0.1 mm position tolerance drops every standstill.
    let o = kincal(
        &[
            "import-bag",
            "b.mcap",
            "--joints",
            "/joint_states",
            "--pose",
            "/tool",
            "--robot",
            "aria",
            "--still-pos-tol-mm",
            "0.1",
            "--out",
            "d.csv",
        ],
        dir.path(),
    );
    assert_eq!(code(&o), 3, "{}", stderr(&o));
    assert!(
        stderr(&o).contains("dropped 4: standstills whose measured position spread"),
        "{}",
        stderr(&o)
    );
}

fn expect_bad(msgs: &[Msg], extra: &[&str], want: &str) {
    let dir = tempfile::tempdir().unwrap();
    write_bag(&dir.path().join("b.mcap"), msgs);
    let mut args = vec![
        "import-bag",
        "b.mcap",
        "--joints",
        "/joint_states",
        "--pose",
        "/tool",
        "--out",
        "d.csv",
    ];
    args.extend(extra);
    let o = kincal(&args, dir.path());
    assert_eq!(code(&o), 3, "{}", stderr(&o));
    assert!(
        stderr(&o).contains(want),
        "want '{want}' in: {}",
        stderr(&o)
    );
    assert!(!dir.path().join("d.csv").exists());
}

#[test]
fn bad_bags_exit_3_with_the_reason() {
    let good = || scenario("geometry_msgs/msg/PoseStamped");
    // Missing topic: the bag's topics are listed.
    let no_pose: Vec<Msg> = good().into_iter().filter(|m| m.topic != "/tool").collect();
    expect_bad(
        &no_pose,
        &["--robot", "aria"],
        "no messages on topic '/tool'; the bag's topics: /joint_states (sensor_msgs/msg/JointState)",
    );
    // Unknown message type on the pose topic.
    let imu: Vec<Msg> = good()
        .into_iter()
        .map(|m| {
            if m.topic == "/tool" {
                Msg {
                    schema: "sensor_msgs/msg/Imu",
                    ..m
                }
            } else {
                m
            }
        })
        .collect();
    expect_bad(
        &imu,
        &["--robot", "aria"],
        "topic '/tool' carries 'sensor_msgs/msg/Imu'",
    );
    // A header clock that jumps back by 5 s on the pose topic.
    let mut jumped = good();
    let k = jumped.iter().rposition(|m| m.topic == "/tool").unwrap() - 50;
    let jump_at = jumped[k].log_ns;
    for m in jumped
        .iter_mut()
        .filter(|m| m.topic == "/tool" && m.log_ns >= jump_at)
    {
        let p = kincal_io::cdr::pose_stamped(&m.data).unwrap();
        m.data = cdr::pose_stamped(
            p.header.stamp_ns - 5_000_000_000,
            "mocap",
            p.position_m,
            p.quaternion_wxyz,
        );
    }
    expect_bad(&jumped, &["--robot", "aria"], "clock jumps back by 4.99");
    // The same jump on the receive clock too (both clocks jump): still refused.
    let mut both = good();
    for m in both
        .iter_mut()
        .filter(|m| m.topic == "/tool" && m.log_ns >= jump_at)
    {
        m.log_ns -= 5_000_000_000;
    }
    expect_bad(
        &both,
        &["--clock", "receive", "--robot", "aria"],
        "clock jumps back",
    );
    // A reading without one of the robot's joints.
    let short: Vec<Msg> = good()
        .into_iter()
        .map(|m| {
            if m.topic == "/joint_states" && m.log_ns > jump_at {
                Msg {
                    data: cdr::joint_state(0, &["joint1", "joint2"], &[0.0, 0.0]),
                    ..m
                }
            } else {
                m
            }
        })
        .collect();
    expect_bad(
        &short,
        &["--robot", "aria"],
        "the robot's joints joint3, joint4, joint5, joint6 are missing",
    );
}

#[test]
fn truncated_and_foreign_files_exit_3() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("b.mcap");
    write_bag(&path, &scenario("geometry_msgs/msg/PoseStamped"));
    let bytes = fs::read(&path).unwrap();
    for (name, content) in [
        ("cut.mcap", bytes[..bytes.len() / 2].to_vec()),
        ("tail.mcap", bytes[..bytes.len() - 3].to_vec()),
        ("text.mcap", b"pose_id,q1\n1,0\n".to_vec()),
        ("empty.mcap", Vec::new()),
    ] {
        fs::write(dir.path().join(name), content).unwrap();
        let o = kincal(
            &[
                "import-bag",
                name,
                "--joints",
                "/joint_states",
                "--pose",
                "/tool",
                "--robot",
                "aria",
                "--out",
                "d.csv",
            ],
            dir.path(),
        );
        assert_eq!(code(&o), 3, "{name}: {}", stderr(&o));
        assert!(
            stderr(&o).contains("not a readable MCAP file"),
            "{name}: {}",
            stderr(&o)
        );
    }
}

#[test]
fn both_measurement_topics_or_none_is_a_usage_error() {
    let dir = tempfile::tempdir().unwrap();
    for extra in [&["--pose", "/a", "--point", "/b"][..], &[][..]] {
        let mut args = vec!["import-bag", "b.mcap", "--joints", "/j", "--out", "d.csv"];
        args.extend(extra);
        let o = kincal(&args, dir.path());
        assert_eq!(code(&o), 2, "{}", stderr(&o));
    }
}

/// The independent writer: Python's `mcap` package with the script's own CDR encoding.
/// Skipped (with a note) where the package is missing, except under CI=true.
#[test]
fn python_written_bag_reads_back_the_script_poses() {
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scripts/write_test_bag.py");
    let dir = tempfile::tempdir().unwrap();
    let bag = dir.path().join("py.mcap");
    // The project's test command points KINCAL_PYTHON at a venv with `mcap` installed.
    let python = std::env::var_os("KINCAL_PYTHON").unwrap_or_else(|| "python3".into());
    let py = Command::new(python).arg(&script).arg(&bag).output();
    let ok = py.as_ref().is_ok_and(|o| o.status.success());
    if !ok {
        let why = py.map_or_else(|e| e.to_string(), |o| stderr(&o));
        assert!(
            std::env::var("CI").as_deref() != Ok("true"),
            "CI must install Python's mcap package (pip install mcap): {why}"
        );
        eprintln!("skipped: Python's mcap package is not installed ({why})");
        return;
    }
    let expected: serde_json::Value =
        serde_json::from_slice(&py.unwrap().stdout).expect("script prints the expected rows");
    let o = kincal(
        &[
            "import-bag",
            "py.mcap",
            "--joints",
            "/joint_states",
            "--pose",
            "/tool_pose",
            "--robot",
            "aria",
            "--out",
            "d.csv",
        ],
        dir.path(),
    );
    assert_eq!(code(&o), 0, "{}", stderr(&o));
    let set = read_rows(&dir.path().join("d.csv"));
    let rows = expected.as_array().unwrap();
    assert_eq!(set.rows.len(), rows.len());
    for (row, e) in set.rows.iter().zip(rows) {
        let f = |k: &str| -> Vec<f64> {
            e[k].as_array()
                .unwrap()
                .iter()
                .map(|v| v.as_f64().unwrap())
                .collect()
        };
        for (a, b) in row.q_rad.iter().zip(f("q")) {
            assert!((a - b).abs() < 1e-12, "{a} vs {b}");
        }
        for (a, b) in row.position_m.unwrap().iter().zip(f("xyz")) {
            assert!((a - b).abs() < 1e-12, "{a} vs {b}");
        }
        let Some(Orientation::Quaternion { w, x, y, z }) = row.orientation else {
            panic!("no orientation");
        };
        let q = f("wxyz");
        let dot = (w * q[0] + x * q[1] + y * q[2] + z * q[3]).abs();
        assert!(1.0 - dot < 1e-12);
    }
}

/// Writes the `ros_bag` fuzz target's seeds (fuzz/seeds/ros_bag): small bags on the topics
/// the target reads (`/joint_states` with joint1, joint2; `/tool` poses), chunked with zstd,
/// chunked uncompressed and unchunked, and each CDR message type alone (the target also
/// decodes its input as one message). Kept small so that mutations stay cheap.
/// `cargo test -p kincal-cli --test import_bag -- --ignored write_fuzz_seeds`
#[test]
#[ignore = "writes the fuzz seeds into the repository"]
fn write_fuzz_seeds() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../fuzz/seeds/ros_bag");
    fs::create_dir_all(&dir).unwrap();
    let stamp = |k: i128| T0_NS + k * JOINT_PERIOD_NS;
    let mut msgs = Vec::new();
    for k in 0..6 {
        let q = if k < 3 { [0.1, -0.2] } else { [0.4, 0.3] };
        msgs.push(Msg {
            topic: "/joint_states",
            schema: "sensor_msgs/msg/JointState",
            log_ns: u64::try_from(stamp(k)).unwrap(),
            data: cdr::joint_state(stamp(k), &["joint1", "joint2"], &q),
        });
        let p = [0.3 + 0.01 * k as f64, 0.0, 0.5];
        let (schema, data) = match k % 3 {
            0 => (
                "geometry_msgs/msg/PoseStamped",
                cdr::pose_stamped(stamp(k), "mocap", p, [1.0, 0.0, 0.0, 0.0]),
            ),
            1 => (
                "geometry_msgs/msg/TransformStamped",
                cdr::transform_stamped(stamp(k), "mocap", "tool", p, [1.0, 0.0, 0.0, 0.0]),
            ),
            _ => (
                "geometry_msgs/msg/PointStamped",
                cdr::point_stamped(stamp(k), "tracker", p),
            ),
        };
        let topic = if k % 3 == 0 { "/tool" } else { "/other" };
        msgs.push(Msg {
            topic,
            schema,
            log_ns: u64::try_from(stamp(k) + 1).unwrap(),
            data,
        });
    }
    let plain = mcap::WriteOptions::new().compression(None);
    write_bag(&dir.join("chunked-zstd.mcap"), &msgs);
    write_bag_with(&dir.join("chunked-plain.mcap"), &msgs, plain.clone());
    write_bag_with(&dir.join("unchunked.mcap"), &msgs, plain.use_chunks(false));
    let p = [0.3, 0.1, 0.5];
    let q = [0.5, 0.5, 0.5, 0.5];
    let cdr_seeds = [
        (
            "joint_state.cdr",
            cdr::joint_state(T0_NS, &["joint1", "joint2"], &[0.1, -0.2]),
        ),
        ("pose_stamped.cdr", cdr::pose_stamped(T0_NS, "mocap", p, q)),
        (
            "transform_stamped.cdr",
            cdr::transform_stamped(T0_NS, "mocap", "tool", p, q),
        ),
        ("point_stamped.cdr", cdr::point_stamped(T0_NS, "tracker", p)),
    ];
    for (name, bytes) in cdr_seeds {
        fs::write(dir.join(name), bytes).unwrap();
    }
}
