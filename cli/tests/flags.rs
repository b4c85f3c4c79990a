//! Flags that agree (#19 item 7): the `--robot` rule the top-level help states holds for
//! every command it names (required where measured data are read, `aria` by default in the
//! design commands).

use std::process::{Command, Output};

fn kincal(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_kincal"))
        .args(args)
        .output()
        .expect("run kincal")
}

fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// The help of `--robot` in a command's options (its flag line and the description lines
/// up to the next option; the usage line that also names the flag is skipped).
fn robot_help(command: &str) -> String {
    let o = kincal(&[command, "--help"]);
    assert_eq!(o.status.code(), Some(0), "{command} --help");
    let help = stdout(&o);
    let mut lines = help
        .lines()
        .skip_while(|l| !l.trim_start().starts_with("--robot <ROBOT>"));
    let first = lines
        .next()
        .unwrap_or_else(|| panic!("{command}: no --robot option in\n{help}"));
    let rest = lines.take_while(|l| !l.trim_start().starts_with('-'));
    std::iter::once(first)
        .chain(rest)
        .collect::<Vec<_>>()
        .join("\n")
}

#[test]
fn the_robot_rule_is_stated_and_kept_by_every_command() {
    let o = kincal(&["--help"]);
    let help = stdout(&o);
    assert!(
        help.contains("--robot: commands that read measured data (calibrate, crossval, diagnose, markers) require"),
        "{help}"
    );
    for command in ["calibrate", "crossval", "diagnose", "markers"] {
        let line = robot_help(command);
        assert!(!line.contains("[default"), "{command}: {line}");
        let o = kincal(&[command, "x.csv"]);
        assert_eq!(o.status.code(), Some(2), "{command} without --robot");
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(err.contains("--robot <ROBOT>"), "{command}: {err}");
    }
    for command in ["select-poses", "design-tool", "evaluate-designs"] {
        let line = robot_help(command);
        assert!(line.contains("[default: aria]"), "{command}: {line}");
    }
}
