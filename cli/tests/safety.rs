//! Nothing lost, nothing hung, nothing silently wrong (issue #16 items 1–6, 11–14; issue
//! #19 item 1): outputs never replace special files, inputs or each other; outputs are
//! checked before any work; readers refuse implausible, unbounded or deeply nested input
//! with the place named; errors blame the right file or option.

use std::fs;
use std::io::Write;
use std::path::Path;
use std::process::{Command, Output};
use std::time::{Duration, Instant};

use kincal_cli::files::{OutputErrorKind, write_atomic};

const BIN: &str = env!("CARGO_BIN_EXE_kincal");

fn kincal(args: &[&str], dir: &Path) -> Output {
    Command::new(BIN)
        .args(args)
        .current_dir(dir)
        .output()
        .expect("run kincal")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn code(o: &Output) -> i32 {
    o.status.code().expect("exit code")
}

fn aria_toml() -> String {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("../docs/robots/aria.toml");
    fs::read_to_string(p).expect("docs/robots/aria.toml")
}

fn put(w: &mut dyn Write, s: &str) -> std::io::Result<()> {
    w.write_all(s.as_bytes())
}

fn entries(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

#[cfg(unix)]
fn mkfifo(p: &Path) {
    let st = Command::new("mkfifo").arg(p).status().expect("mkfifo");
    assert!(st.success());
}

#[cfg(unix)]
fn is_fifo(p: &Path) -> bool {
    use std::os::unix::fs::FileTypeExt;
    fs::symlink_metadata(p).unwrap().file_type().is_fifo()
}

// ---- 1. write_atomic writes only regular files ----------------------------------------

#[cfg(unix)]
#[test]
fn write_atomic_refuses_a_fifo_and_a_symlink_to_one() {
    let dir = tempfile::tempdir().unwrap();
    let fifo = dir.path().join("null");
    mkfifo(&fifo);
    let e = write_atomic(&fifo, &[], |w| put(w, "x")).unwrap_err();
    assert_eq!(e.kind, OutputErrorKind::Io);
    assert!(e.to_string().contains("FIFO"), "{e}");
    assert!(is_fifo(&fifo), "the FIFO was replaced");
    // The same through a symlink (what `--out /dev/null` looks like to the writer).
    let link = dir.path().join("link");
    std::os::unix::fs::symlink(&fifo, &link).unwrap();
    let e = write_atomic(&link, &[], |w| put(w, "x")).unwrap_err();
    assert!(e.to_string().contains("FIFO"), "{e}");
    assert!(is_fifo(&fifo));
    assert!(
        fs::symlink_metadata(&link)
            .unwrap()
            .file_type()
            .is_symlink()
    );
    assert_eq!(entries(dir.path()), vec!["link", "null"]);
}

#[cfg(unix)]
#[test]
fn cli_output_to_a_fifo_is_refused_before_any_work() {
    let dir = tempfile::tempdir().unwrap();
    mkfifo(&dir.path().join("pipe"));
    let t = Instant::now();
    let o = kincal(
        &["evaluate-designs", "--runs", "100000", "--json", "pipe"],
        dir.path(),
    );
    assert_eq!(code(&o), 2, "{}", stderr(&o));
    assert!(stderr(&o).contains("--json 'pipe'"), "{}", stderr(&o));
    assert!(stderr(&o).contains("FIFO"), "{}", stderr(&o));
    assert!(t.elapsed() < Duration::from_secs(5), "{:?}", t.elapsed());
    assert!(is_fifo(&dir.path().join("pipe")));
}

#[cfg(unix)]
#[test]
fn write_atomic_follows_a_symlink_to_a_regular_file_and_keeps_the_link() {
    let dir = tempfile::tempdir().unwrap();
    fs::create_dir(dir.path().join("models")).unwrap();
    let real = dir.path().join("models").join("v3.json");
    fs::write(&real, "old").unwrap();
    let link = dir.path().join("model.json");
    std::os::unix::fs::symlink("models/v3.json", &link).unwrap();
    write_atomic(&link, &[], |w| put(w, "new")).unwrap();
    assert!(
        fs::symlink_metadata(&link)
            .unwrap()
            .file_type()
            .is_symlink()
    );
    assert_eq!(fs::read_to_string(&real).unwrap(), "new");
    assert_eq!(entries(&dir.path().join("models")), vec!["v3.json"]);
    // A dangling link is refused; nothing is created at its far end.
    let dangling = dir.path().join("dangling.json");
    std::os::unix::fs::symlink("models/none.json", &dangling).unwrap();
    let e = write_atomic(&dangling, &[], |w| put(w, "x")).unwrap_err();
    assert!(e.to_string().contains("symlink"), "{e}");
    assert!(!dir.path().join("models/none.json").exists());
}

#[cfg(unix)]
#[test]
fn write_atomic_keeps_the_mode_and_refuses_a_write_protected_file() {
    use std::os::unix::fs::PermissionsExt;
    let dir = tempfile::tempdir().unwrap();
    let secret = dir.path().join("secret.json");
    fs::write(&secret, "old").unwrap();
    fs::set_permissions(&secret, fs::Permissions::from_mode(0o600)).unwrap();
    write_atomic(&secret, &[], |w| put(w, "new")).unwrap();
    assert_eq!(fs::read_to_string(&secret).unwrap(), "new");
    let mode = fs::metadata(&secret).unwrap().permissions().mode() & 0o7777;
    assert_eq!(mode, 0o600);

    let locked = dir.path().join("locked.json");
    fs::write(&locked, "keep").unwrap();
    fs::set_permissions(&locked, fs::Permissions::from_mode(0o444)).unwrap();
    let e = write_atomic(&locked, &[], |w| put(w, "x")).unwrap_err();
    assert!(e.to_string().contains("write-protected"), "{e}");
    assert_eq!(fs::read_to_string(&locked).unwrap(), "keep");
    let mode = fs::metadata(&locked).unwrap().permissions().mode() & 0o7777;
    assert_eq!(mode, 0o444);
}

#[test]
fn temporary_files_are_named_after_the_output_and_stale_ones_are_removed() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out.csv");
    // A killed run's leftover (no such process) and a live run's file (this process).
    let stale = ".kincal-out.csv-4000000000-AbCdEf.tmp".to_string();
    let live = format!(".kincal-out.csv-{}-XyZ123.tmp", std::process::id());
    let other = ".kincal-other.csv-4000000000-AbCdEf.tmp".to_string();
    for f in [&stale, &live, &other] {
        fs::write(dir.path().join(f), "partial").unwrap();
    }
    let mut seen = String::new();
    write_atomic(&out, &[], |w| {
        // While writing, the temporary file names the output and this process.
        seen = entries(dir.path())
            .into_iter()
            .find(|e| {
                e.starts_with(&format!(".kincal-out.csv-{}-", std::process::id())) && *e != live
            })
            .unwrap_or_default();
        put(w, "x")
    })
    .unwrap();
    assert!(seen.ends_with(".tmp"), "temporary file: '{seen}'");
    let left = entries(dir.path());
    if Path::new("/proc/self").exists() {
        assert!(!left.contains(&stale), "{left:?}");
    }
    assert!(
        left.contains(&live),
        "a live run's file was removed: {left:?}"
    );
    assert!(
        left.contains(&other),
        "another output's file was removed: {left:?}"
    );
    assert!(left.contains(&"out.csv".to_string()));
}

// ---- 2. one plan of inputs and outputs, checked before any work ------------------------

/// Runs `args` in a folder holding `R.toml` (a robot), `tool.csv`, `data.csv`; asserts exit
/// 2 within seconds, the message naming `flags`, and every file unchanged.
#[track_caller]
fn assert_refused_at_once(args: &[&str], flags: &[&str]) {
    let dir = tempfile::tempdir().unwrap();
    fs::write(dir.path().join("R.toml"), aria_toml()).unwrap();
    fs::write(dir.path().join("tool.csv"), "pose_id,x,y,z\n").unwrap();
    fs::write(dir.path().join("data.csv"), "q1\n").unwrap();
    fs::write(dir.path().join("e.csv"), "frame\n").unwrap();
    fs::write(dir.path().join("d.toml"), "x = 1\n").unwrap();
    fs::write(dir.path().join("j.csv"), "frame\n").unwrap();
    let before: Vec<(String, Vec<u8>)> = entries(dir.path())
        .into_iter()
        .map(|e| (e.clone(), fs::read(dir.path().join(&e)).unwrap()))
        .collect();
    let t = Instant::now();
    let o = kincal(args, dir.path());
    let e = stderr(&o);
    assert_eq!(code(&o), 2, "{args:?}: {e}");
    for f in flags {
        assert!(e.contains(f), "{args:?}: '{f}' not named: {e}");
    }
    assert!(
        t.elapsed() < Duration::from_secs(5),
        "{args:?}: {:?}",
        t.elapsed()
    );
    let after: Vec<(String, Vec<u8>)> = entries(dir.path())
        .into_iter()
        .map(|e| (e.clone(), fs::read(dir.path().join(&e)).unwrap()))
        .collect();
    assert_eq!(before, after, "{args:?}: files changed");
}

#[test]
fn no_command_overwrites_its_input() {
    assert_refused_at_once(
        &["predict", "R.toml", "data.csv", "--out", "R.toml"],
        &["--out", "MODEL"],
    );
    assert_refused_at_once(
        &["select-poses", "--robot", "R.toml", "--out", "R.toml"],
        &["--out", "--robot"],
    );
    assert_refused_at_once(
        &[
            "design-tool",
            "--baseline",
            "b=tool.csv",
            "--out",
            "tool.csv",
        ],
        &["--out", "--baseline"],
    );
    assert_refused_at_once(
        &[
            "design-tool",
            "--baseline",
            "b=tool.csv",
            "--out",
            "new.csv",
            "--plot",
            "./tool.csv",
        ],
        &["--plot", "--baseline"],
    );
    assert_refused_at_once(
        &[
            "evaluate-designs",
            "--tool",
            "t=tool.csv",
            "--plot",
            "tool.csv",
        ],
        &["--plot", "--tool"],
    );
    assert_refused_at_once(
        &[
            "evaluate-designs",
            "--commanded",
            "c=tool.csv",
            "--json",
            "tool.csv",
        ],
        &["--json", "--commanded"],
    );
    assert_refused_at_once(
        &["evaluate-designs", "--robot", "R.toml", "--json", "R.toml"],
        &["--json", "--robot"],
    );
    assert_refused_at_once(
        &[
            "markers", "e.csv", "--design", "d.toml", "--joints", "j.csv", "--robot", "R.toml",
            "--out", "R.toml",
        ],
        &["--out", "--robot"],
    );
    assert_refused_at_once(
        &[
            "calibrate",
            "data.csv",
            "--robot",
            "R.toml",
            "--out",
            "R.toml",
        ],
        &["--out", "--robot"],
    );
}

#[cfg(unix)]
#[test]
fn an_input_reached_through_a_symlinked_output_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    fs::write(dir.path().join("R.toml"), aria_toml()).unwrap();
    std::os::unix::fs::symlink("R.toml", dir.path().join("poses.csv")).unwrap();
    let o = kincal(
        &["select-poses", "--robot", "R.toml", "--out", "poses.csv"],
        dir.path(),
    );
    assert_eq!(code(&o), 2, "{}", stderr(&o));
    assert_eq!(
        fs::read_to_string(dir.path().join("R.toml")).unwrap(),
        aria_toml()
    );
}

#[test]
fn two_outputs_naming_one_file_are_refused() {
    assert_refused_at_once(
        &[
            "validate", "aria", "data.csv", "--plot", "x.svg", "--json", "x.svg",
        ],
        &["--plot", "--json"],
    );
    assert_refused_at_once(
        &["design-tool", "--out", "x.csv", "--json", "./x.csv"],
        &["--out", "--json"],
    );
    assert_refused_at_once(
        &["evaluate-designs", "--plot", "x", "--json", "x"],
        &["--plot", "--json"],
    );
    assert_refused_at_once(
        &[
            "crossval",
            "data.csv",
            "--robot",
            "aria",
            "--json",
            "x",
            "--robot-out",
            "x",
        ],
        &["--json", "--robot-out"],
    );
}

#[test]
fn an_output_in_a_missing_folder_is_refused_before_any_work() {
    assert_refused_at_once(
        &[
            "evaluate-designs",
            "--runs",
            "100000",
            "--json",
            "no/such/r.json",
        ],
        &["--json", "does not exist"],
    );
    assert_refused_at_once(
        &["design-tool", "--out", "missing/tool.csv"],
        &["--out", "does not exist"],
    );
    assert_refused_at_once(
        &["select-poses", "--out", "missing/poses.csv"],
        &["--out", "does not exist"],
    );
    assert_refused_at_once(
        &[
            "diagnose", "data.csv", "--robot", "aria", "--json", "r/R.json", "--out", "m.json",
        ],
        &["--json", "does not exist"],
    );
    assert_refused_at_once(
        &["calibrate", "data.csv", "--robot", "aria", "--out", "."],
        &["--out", "names no file"],
    );
}
