use std::path::PathBuf;

use kincal::any::AnyRobot;
use kincal::aria;
use kincal::model::LengthParam;

use super::*;

fn workspace_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// The shipped ARIA file is exactly the built-in model.
#[test]
fn aria_file_is_builtin_aria() {
    let desc = load_robot_file(&workspace_root().join("docs/robots/aria.toml")).expect("aria.toml");
    assert_eq!(desc.name, "aria");
    assert_eq!(desc.joint_names[2], "joint3");
    match &desc.robot {
        AnyRobot::J6(r) => assert_eq!(*r, aria::nominal()),
        other => panic!("expected 6 joints, got {}", other.n_joints()),
    }
}

/// Writing and reading back gives the same robot, also for non-trivial frames and overrides.
#[test]
fn write_read_round_trip() {
    let mut r = aria::nominal()
        .with_base([0.1, -0.2, 0.3, 0.4, -0.5, 0.6])
        .unwrap()
        .with_tool([0.01, 0.02, 0.03, 3.0, 0.1, -0.2])
        .unwrap();
    r.set_length_param(3, LengthParam::Beta).unwrap();
    let desc = RobotDescription {
        name: "aria \"modified\"".into(),
        joint_names: (1..=6).map(|i| format!("j{i}")).collect(),
        robot: AnyRobot::from(r),
    };
    let text = write_robot_description(&desc);
    let back = parse_robot_description(&text, "roundtrip.toml").expect("parse");
    assert_eq!(back, desc, "{text}");
    // And the built-in ARIA through the writer.
    let desc = RobotDescription {
        name: "aria".into(),
        joint_names: (1..=6).map(|i| format!("joint{i}")).collect(),
        robot: AnyRobot::from(aria::nominal()),
    };
    let back = parse_robot_description(&write_robot_description(&desc), "x.toml").unwrap();
    assert_eq!(back, desc);
}

const MINIMAL: &str = r#"name = "two"

[[joint]]
theta0 = 0
d_mm = 100
a = 0.2
alpha_deg = 90
lower = -1
upper = 1

[[joint]]
theta0 = 0.1
d = 0.0
a_mm = 150
alpha = 0.0
lower_deg = -90
upper_deg = 90
"#;

#[test]
fn suffixes_and_defaults() {
    let desc = parse_robot_description(MINIMAL, "two.toml").expect("parse");
    assert_eq!(desc.joint_names, vec!["joint1", "joint2"]);
    let AnyRobot::J2(r) = &desc.robot else {
        panic!("expected 2 joints");
    };
    {
        let l = r.links();
        assert_eq!(l[0].d, 0.1);
        assert_eq!(l[0].alpha, std::f64::consts::FRAC_PI_2);
        assert_eq!(l[1].a, 0.15);
        assert_eq!(r.limits()[1].upper, std::f64::consts::FRAC_PI_2);
        assert_eq!(r.base(), [0.0; 6]);
        assert_eq!(r.mass().gravity, [0.0, 0.0, -9.81]);
    }
}

/// Each bad input is rejected with the file, the line of the offending key and a reason.
#[test]
fn errors_name_file_line_key_reason() {
    let cases: &[(&str, &str, usize, &str, &str)] = &[
        // (replace, with, expected line, expected key substring, reason substring)
        (
            "d_mm = 100",
            "d_mm = 100\nd = 0.1",
            6,
            "joint[1].d",
            "both given",
        ),
        (
            "upper = 1\n",
            "upper = -2\n",
            9,
            "joint[1].upper",
            "below the lower limit",
        ),
        ("a = 0.2", "a = nan", 6, "joint[1].a", "not a finite number"),
        ("a = 0.2", "a = 0.2\nfoo = 1", 7, "", "unknown field `foo`"),
        ("a = 0.2", "a = \"x\"", 6, "", "invalid type"),
        (
            "alpha = 0.0\n",
            "alpha = 0.0\nlength_param = \"q\"\n",
            16,
            "joint[2].length_param",
            "expected \"d\" or \"beta\"",
        ),
        (
            "a_mm = 150\n",
            "a_mm = 150\nmass_kg = -1\n",
            15,
            "joint[2].mass_kg",
            "negative",
        ),
    ];
    for (from, to, line, key, reason) in cases {
        let text = MINIMAL.replacen(from, to, 1);
        assert_ne!(text, MINIMAL);
        let e = parse_robot_description(&text, "bad.toml").unwrap_err();
        let shown = e.to_string();
        assert_eq!(e.file, "bad.toml", "{shown}");
        assert_eq!(e.line, Some(*line), "{shown}");
        assert!(e.key.clone().unwrap_or_default().contains(key), "{shown}");
        assert!(shown.contains(reason), "{shown}");
        assert!(shown.starts_with(&format!("bad.toml:{line}:")), "{shown}");
    }
    // A missing quantity names the key (no line: it is not in the file).
    let e = parse_robot_description(&MINIMAL.replacen("a = 0.2\n", "", 1), "m.toml").unwrap_err();
    assert_eq!(e.key.as_deref(), Some("joint[1].a"), "{e}");
    assert!(e.to_string().contains("give `a` or `a_mm`"), "{e}");
    // Base with both rotation forms.
    let text = format!("{MINIMAL}\n[base]\nrpy = [0, 0, 1]\nrotvec = [0, 0, 1]\n");
    let e = parse_robot_description(&text, "b.toml").unwrap_err();
    assert_eq!(e.key.as_deref(), Some("base.rotvec"), "{e}");
    // Syntax error: line of the error.
    let e = parse_robot_description("name = \"x\"\n[[joint]\n", "s.toml").unwrap_err();
    assert_eq!(e.line, Some(2), "{e}");
}

/// The example in docs/robot-description.md parses to what the text says.
#[test]
fn documented_example_parses() {
    let doc = std::fs::read_to_string(workspace_root().join("docs/robot-description.md")).unwrap();
    let start = doc.find("```toml\n").expect("toml block") + "```toml\n".len();
    let end = start + doc[start..].find("```").unwrap();
    let example = &doc[start..end];
    let desc = parse_robot_description(example, "planar2.toml").expect("example");
    assert_eq!(desc.joint_names, vec!["shoulder", "elbow"]);
    let AnyRobot::J2(r) = &desc.robot else {
        panic!("expected 2 joints");
    };
    assert_eq!(r.length_params()[0], LengthParam::Beta);
    assert!((r.base()[2] - 0.4).abs() < 1e-15);
    assert!((r.base()[5] - std::f64::consts::FRAC_PI_2).abs() < 1e-15);
    assert_eq!(r.tool()[2], 0.05);
    assert_eq!(r.mass().tool_mass_kg, 0.5);
    // The error lines quoted in the doc.
    let errs = [
        example.replacen("a_mm = 300\n", "a_mm = 300\na = 0.3\n", 1),
        example.replacen("upper_deg = 170", "upper = -3", 1),
        example.replacen("tool_kg = 0.5", "weight = 0.5", 1),
    ];
    for text in errs {
        let e = parse_robot_description(&text, "planar2.toml")
            .unwrap_err()
            .to_string();
        assert!(
            doc.contains(&format!("    {e}\n")),
            "doc does not quote: {e}"
        );
    }
}
