//! `include/kincal.h` must be what the pinned cbindgen generates from this crate now.
//! Regenerate with `KINCAL_BLESS=1 cargo test -p kincal-ffi header`.

use std::path::{Path, PathBuf};

const REGENERATE: &str = "KINCAL_BLESS=1 cargo test -p kincal-ffi header";

fn crate_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn generate() -> String {
    let dir = crate_dir();
    let config = cbindgen::Config::from_file(dir.join("cbindgen.toml"))
        .unwrap_or_else(|e| panic!("reading ffi/cbindgen.toml: {e}"));
    let bindings = cbindgen::Builder::new()
        .with_config(config)
        .with_src(dir.join("src").join("lib.rs"))
        .generate()
        .unwrap_or_else(|e| panic!("cbindgen failed: {e}"));
    let mut out = Vec::new();
    bindings.write(&mut out);
    String::from_utf8(out).unwrap_or_else(|e| panic!("cbindgen wrote non-UTF-8: {e}"))
}

/// The first differing lines, with a little context, as a readable report.
fn line_diff(expected: &str, actual: &str) -> String {
    let (e, a): (Vec<_>, Vec<_>) = (expected.lines().collect(), actual.lines().collect());
    let first = e
        .iter()
        .zip(a.iter())
        .position(|(x, y)| x != y)
        .unwrap_or(e.len().min(a.len()));
    let mut report = format!(
        "first difference at line {} (committed {} lines, generated {} lines)\n",
        first + 1,
        e.len(),
        a.len()
    );
    for i in first.saturating_sub(2)..(first + 8) {
        match (e.get(i), a.get(i)) {
            (Some(x), Some(y)) if x == y => report += &format!("  {x}\n"),
            (x, y) => {
                if let Some(x) = x {
                    report += &format!("- {x}\n");
                }
                if let Some(y) = y {
                    report += &format!("+ {y}\n");
                }
            }
        }
    }
    report
}

fn check(path: &Path, generated: &str) {
    if std::env::var_os("KINCAL_BLESS").is_some() {
        std::fs::write(path, generated)
            .unwrap_or_else(|e| panic!("writing {}: {e}", path.display()));
        return;
    }
    let committed = std::fs::read_to_string(path).unwrap_or_default();
    assert!(
        committed == generated,
        "{} is stale: {}\nRegenerate it with:\n    {REGENERATE}",
        path.display(),
        line_diff(&committed, generated)
    );
}

#[test]
fn header_is_up_to_date() {
    let header = crate_dir().join("..").join("include").join("kincal.h");
    check(&header, &generate());
}

#[test]
fn header_diff_names_the_line() {
    let d = line_diff("a\nb\nc\n", "a\nx\nc\n");
    assert!(d.contains("line 2"), "{d}");
    assert!(d.contains("- b") && d.contains("+ x"), "{d}");
}

#[test]
fn header_contains_the_conventions() {
    let h = generate();
    for needle in [
        "#ifndef KINCAL_H",
        "DO NOT EDIT",
        REGENERATE,
        "KINCAL_STATUS_OK = 0",
        "KINCAL_STATUS_PANIC = 999",
        "typedef uint32_t kincal_status;",
        "#if defined(KINCAL_TEST_PANIC)",
        "size_t q_len",
        "extern \"C\"",
    ] {
        assert!(h.contains(needle), "generated header lacks {needle:?}");
    }
}

/// The exports `kincal-...` named in `text`, sorted and deduplicated.
fn export_names(text: &str) -> Vec<String> {
    let mut names: Vec<String> = text
        .split(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
        .filter(|w| w.starts_with("kincal_") && w.len() > "kincal_".len())
        .map(str::to_owned)
        .collect();
    names.sort();
    names.dedup();
    names
}

#[test]
fn unproven_exports_are_documented() {
    // tests/cpp/panic_never.sh reads the list file; ffi/README.md documents it: one list.
    let list = std::fs::read_to_string(crate_dir().join("../tests/cpp/not_panic_proven.txt"))
        .expect("tests/cpp/not_panic_proven.txt");
    let listed: String = list
        .lines()
        .map(|l| l.split('#').next().unwrap_or("").trim())
        .filter(|l| !l.is_empty())
        .map(|l| format!("{l}\n"))
        .collect();
    let readme = std::fs::read_to_string(crate_dir().join("README.md")).expect("ffi/README.md");
    let documented = readme
        .split("<!-- not-panic-proven")
        .nth(1)
        .and_then(|rest| rest.split("<!-- /not-panic-proven -->").next())
        .and_then(|rest| rest.split("-->").nth(1))
        .expect("ffi/README.md has the not-panic-proven block");
    let listed = export_names(&listed);
    assert!(!listed.is_empty());
    assert_eq!(export_names(documented), listed);
    // Every listed name is an export of the header (a stale entry would hide nothing).
    let header = std::fs::read_to_string(crate_dir().join("../include/kincal.h")).unwrap();
    for name in &listed {
        assert!(
            header.contains(&format!(" {name}(")),
            "{name} is not in include/kincal.h"
        );
    }
}
