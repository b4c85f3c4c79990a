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

/// The flags of a command's `--help` (`--name` at the start of a line of its options).
fn flags_of(command: &str) -> Vec<String> {
    let o = kincal(&[command, "--help"]);
    assert_eq!(o.status.code(), Some(0), "{command} --help");
    stdout(&o)
        .lines()
        .skip_while(|l| !l.starts_with("Options:"))
        .filter_map(|l| {
            let l = l.trim_start();
            let l = l.strip_prefix("-m, ").unwrap_or(l);
            l.strip_prefix("--")
                .map(|f| f.split([' ', ',', '=']).next().unwrap_or("").to_string())
        })
        .collect()
}

/// #19 item 7: each design command lists only the flags it uses, and one it does not use is
/// refused (exit 2) instead of being accepted and ignored.
#[test]
fn design_commands_take_only_the_flags_they_use() {
    let noise = [
        "noise-pos-mm",
        "noise-rot-deg",
        "tool-tol-mm",
        "tool-tol-deg",
    ];
    let pool = [
        "index",
        "pool",
        "refine",
        "workspace",
        "cube-mm",
        "tolerance",
    ];
    let common = [
        "robot",
        "region",
        "seed",
        "poses",
        "starts",
        "min-dexterity",
        "robust-robots",
        "length-error-mm",
        "angle-error-deg",
    ];
    let select = flags_of("select-poses");
    let tool = flags_of("design-tool");
    let evaluate = flags_of("evaluate-designs");
    for f in common {
        for (c, flags) in [
            ("select-poses", &select),
            ("design-tool", &tool),
            ("evaluate-designs", &evaluate),
        ] {
            assert!(flags.iter().any(|g| g == f), "{c} lacks --{f}: {flags:?}");
        }
    }
    for f in noise {
        assert!(!select.iter().any(|g| g == f), "select-poses lists --{f}");
        assert!(
            tool.iter().any(|g| g == f) && evaluate.iter().any(|g| g == f),
            "--{f}"
        );
    }
    for f in pool {
        assert!(!tool.iter().any(|g| g == f), "design-tool lists --{f}");
        assert!(
            select.iter().any(|g| g == f) && evaluate.iter().any(|g| g == f),
            "--{f}"
        );
    }
    // Refused before any work, naming the flag.
    for (args, flag) in [
        (
            &["select-poses", "--noise-pos-mm", "0.1", "--out", "x.csv"][..],
            "--noise-pos-mm",
        ),
        (
            &["design-tool", "--pool", "100", "--out", "t.csv"][..],
            "--pool",
        ),
    ] {
        let o = kincal(args);
        assert_eq!(o.status.code(), Some(2), "{args:?}");
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(err.contains(flag), "{args:?}: {err}");
    }
}

/// The commands `kincal --help` lists (its `Commands:` section, `help` aside).
fn commands() -> Vec<String> {
    let o = kincal(&["--help"]);
    stdout(&o)
        .lines()
        .skip_while(|l| !l.starts_with("Commands:"))
        .skip(1)
        .take_while(|l| l.starts_with("  "))
        .filter_map(|l| l.split_whitespace().next().map(str::to_string))
        .filter(|c| c != "help")
        .collect()
}

/// Issue #19: every help text fits 100 columns: the top-level help in its three spellings
/// and every command's short (`-h`) and long (`--help`) help, also when `COLUMNS` claims a
/// wider screen (clap wraps to it without a terminal; the cap holds).
#[test]
fn every_help_fits_100_columns() {
    let commands = commands();
    assert!(commands.len() >= 14, "commands found: {commands:?}");
    let mut runs: Vec<Vec<String>> = vec![
        vec!["--help".into()],
        vec!["-h".into()],
        vec!["help".into()],
    ];
    for c in &commands {
        runs.push(vec![c.clone(), "--help".into()]);
        runs.push(vec![c.clone(), "-h".into()]);
        runs.push(vec!["help".into(), c.clone()]);
    }
    let mut widest = (0, String::new());
    for columns in [None, Some("250")] {
        for args in &runs {
            let mut cmd = Command::new(env!("CARGO_BIN_EXE_kincal"));
            cmd.args(args);
            match columns {
                Some(c) => cmd.env("COLUMNS", c),
                None => cmd.env_remove("COLUMNS"),
            };
            let o = cmd.output().expect("run kincal");
            assert_eq!(o.status.code(), Some(0), "{args:?}");
            let help = stdout(&o);
            assert!(help.lines().count() > 3, "{args:?}: {help}");
            for line in help.lines() {
                let n = line.chars().count();
                assert!(
                    n <= 100,
                    "{args:?} (COLUMNS {columns:?}): a line of {n} columns:\n{line}"
                );
                if n > widest.0 {
                    widest = (n, format!("{args:?}"));
                }
            }
        }
    }
    eprintln!(
        "{} help texts, widest line {} columns ({})",
        runs.len() * 2,
        widest.0,
        widest.1
    );
}
