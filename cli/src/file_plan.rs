//! Every input and output path of every command, collected in one place and checked before
//! any work starts: an output never names an input (also through a symlink, a hard link or
//! another spelling), two outputs never name the same file, and each output is writable
//! (an existing regular file or an absent name in an existing folder, see
//! [`kincal_io::files::output_target`]). A failure is a usage error (exit 2) that names the
//! flags, so a long computation never ends in an unwritable output or a lost input.
//!
//! A command with a new file argument adds it to its function below; `write_atomic` checks
//! the same rules again when it writes (defence in depth).

use std::path::{Path, PathBuf};

use crate::error::CliError;
use kincal_io::files::{is_same_file, output_target};

/// A path and the argument (flag or positional name) it came from.
#[derive(Debug, Clone, PartialEq, Eq)]
struct Named {
    flag: String,
    path: PathBuf,
}

/// The files a command reads and writes.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct FilePlan {
    inputs: Vec<Named>,
    outputs: Vec<Named>,
}

impl FilePlan {
    pub fn new() -> Self {
        Self::default()
    }

    /// An input file.
    pub fn input(mut self, flag: &str, path: &Path) -> Self {
        self.inputs.push(Named {
            flag: flag.to_string(),
            path: path.to_path_buf(),
        });
        self
    }

    /// An optional input file.
    pub fn input_opt(self, flag: &str, path: Option<&Path>) -> Self {
        match path {
            Some(p) => self.input(flag, p),
            None => self,
        }
    }

    /// A ROBOT or MODEL argument: an input when it names an existing file (a built-in
    /// name such as `aria` is not a file).
    pub fn input_if_file(self, flag: &str, arg: &str) -> Self {
        let p = Path::new(arg);
        if p.is_file() {
            self.input(flag, p)
        } else {
            self
        }
    }

    /// A `NAME=FILE` argument: the FILE part, if the argument has one.
    pub fn named_input(self, flag: &str, arg: &str) -> Self {
        match arg.split_once('=') {
            Some((_, f)) if !f.is_empty() => self.input(flag, Path::new(f)),
            _ => self,
        }
    }

    /// Every file directly inside the folder `dir` (a data set read as a folder).
    pub fn input_folder(mut self, flag: &str, dir: &Path) -> Self {
        if let Ok(rd) = std::fs::read_dir(dir) {
            for e in rd.flatten() {
                if e.path().is_file() {
                    self = self.input(flag, &e.path());
                }
            }
        }
        self
    }

    /// An output file.
    pub fn output(mut self, flag: &str, path: &Path) -> Self {
        self.outputs.push(Named {
            flag: flag.to_string(),
            path: path.to_path_buf(),
        });
        self
    }

    /// An optional output file.
    pub fn output_opt(self, flag: &str, path: Option<&Path>) -> Self {
        match path {
            Some(p) => self.output(flag, p),
            None => self,
        }
    }

    /// Refuses the plan (exit 2, naming the flags) if an output is unwritable, names an
    /// input, or names the same file as an earlier output.
    pub fn check(&self) -> Result<(), CliError> {
        for (k, out) in self.outputs.iter().enumerate() {
            if let Some(input) = self
                .inputs
                .iter()
                .find(|i| is_same_file(&out.path, &i.path))
            {
                return Err(CliError::usage(format!(
                    "{} '{}' names the same file as the input {} '{}': an input is never overwritten; choose another output path",
                    out.flag,
                    out.path.display(),
                    input.flag,
                    input.path.display()
                )));
            }
            if let Some(other) = self.outputs[..k]
                .iter()
                .find(|o| o.path == out.path || is_same_file(&out.path, &o.path))
            {
                return Err(CliError::usage(format!(
                    "{} '{}' and {} '{}' name the same file: one output would be lost; give them different paths",
                    other.flag,
                    other.path.display(),
                    out.flag,
                    out.path.display()
                )));
            }
            output_target(&out.path)
                .and_then(|t| probe_folder(&t.path))
                .map_err(|reason| {
                    CliError::usage(format!(
                        "{} '{}': cannot write there: {reason}",
                        out.flag,
                        out.path.display()
                    ))
                })?;
        }
        Ok(())
    }
}

/// Creates and removes a temporary file beside `target`: the folder accepts the atomic
/// write's temporary file (permissions, a read-only file system), checked before the work
/// rather than after it.
fn probe_folder(target: &Path) -> Result<(), String> {
    let dir = match target.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    tempfile::Builder::new()
        .prefix(".kincal-probe-")
        .suffix(".tmp")
        .tempfile_in(dir)
        .map(drop)
        .map_err(|e| {
            format!(
                "cannot create a file in the folder '{}': {e}",
                dir.display()
            )
        })
}

/// `calibrate`.
pub fn calibrate(a: &crate::commands::calibrate::Args) -> FilePlan {
    FilePlan::new()
        .input("DATA", &a.data)
        .input_if_file("--robot", &a.robot)
        .input_opt("--constraints", a.constraints.as_deref())
        .output("--out", &a.out)
}

/// `predict`.
pub fn predict(a: &crate::commands::predict::Args) -> FilePlan {
    FilePlan::new()
        .input_if_file("MODEL", &a.model)
        .input("DATA", &a.data)
        .output("--out", &a.out)
}

/// `validate`.
pub fn validate(a: &crate::commands::validate::Args) -> FilePlan {
    FilePlan::new()
        .input_if_file("MODEL", &a.model)
        .input("DATA", &a.data)
        .input_opt("--constraints", a.constraints.as_deref())
        .output_opt("--plot", a.plot.as_deref())
        .output_opt("--json", a.json.as_deref())
}

/// `select-poses`.
pub fn select_poses(a: &crate::commands::select::Args) -> FilePlan {
    FilePlan::new()
        .input_if_file("--robot", &a.setup.robot)
        .output("--out", &a.out)
}

/// `design-tool`.
pub fn design_tool(a: &crate::commands::design_tool::Args) -> FilePlan {
    let mut p = FilePlan::new().input_if_file("--robot", &a.setup.robot);
    if let Some(b) = &a.baseline {
        p = p.named_input("--baseline", b);
    }
    p.output("--out", &a.out)
        .output_opt("--plot", a.plot.as_deref())
        .output_opt("--json", a.json.as_deref())
}

/// `evaluate-designs`.
pub fn evaluate_designs(a: &crate::commands::evaluate::Args) -> FilePlan {
    let mut p = FilePlan::new().input_if_file("--robot", &a.setup.robot);
    for t in &a.tools {
        p = p.named_input("--tool", t);
    }
    for c in &a.commanded {
        p = p.named_input("--commanded", c);
    }
    p.output_opt("--plot", a.plot.as_deref())
        .output_opt("--json", a.json.as_deref())
        .output_opt("--plate-plot", a.plate_plot.as_deref())
}

/// `diagnose`: REPORT.json, the readable report, MODEL and the three plots named after
/// REPORT.json.
pub fn diagnose(a: &crate::commands::diagnose::Args) -> FilePlan {
    let o = crate::plots::diagnosis::Outputs::new(&a.json, a.report.as_deref(), &a.out);
    FilePlan::new()
        .input("DATA", &a.data)
        .input_if_file("--robot", &a.robot)
        .output("--out", &o.model)
        .output("--json", &o.json)
        .output(
            if a.report.is_some() {
                "--report"
            } else {
                "--report (default: --json with .txt)"
            },
            &o.report,
        )
        .output("--json (its _residuals.svg plot)", &o.plot_residuals)
        .output("--json (its _correlate.svg plot)", &o.plot_correlate)
        .output("--json (its _candidates.svg plot)", &o.plot_candidates)
}

/// `crossval`.
pub fn crossval(a: &crate::commands::crossval::Args) -> FilePlan {
    FilePlan::new()
        .input("DATA", &a.data)
        .input_if_file("--robot", &a.robot)
        .input_opt("--constraints", a.constraints.as_deref())
        .output_opt("--json", a.json.as_deref())
        .output_opt("--plot", a.plot.as_deref())
        .output_opt("--robot-out", a.robot_out.as_deref())
}

/// `markers`.
pub fn markers(a: &crate::commands::markers::Args) -> FilePlan {
    FilePlan::new()
        .input("EXPORT", &a.export)
        .input("--design", &a.design)
        .input("--joints", &a.joints)
        .input_if_file("--robot", &a.robot)
        .output("--out", &a.out)
        .output_opt("--residuals", a.residuals.as_deref())
}

/// `import-dataset`.
pub fn import_dataset(a: &crate::commands::import::Args) -> FilePlan {
    let mut p = FilePlan::new();
    if let Some(d) = &a.dir {
        p = p.input_folder("DIR", d);
    }
    if let Some(u) = &a.urdf {
        p = p.input("--urdf", u);
    }
    p.output_opt("--out", a.out.as_deref())
        .output_opt("--robot-out", a.robot_out.as_deref())
        .output_opt("--constraints-out", a.constraints_out.as_deref())
}

/// `import-bag`: the bag (a file or the files of its folder), a ROBOT file, the CSV.
pub fn import_bag(a: &crate::commands::import_bag::Args) -> FilePlan {
    let mut p = FilePlan::new();
    for f in crate::commands::import_bag::bag_inputs(&a.bag) {
        p = p.input("BAG", &f);
    }
    if let Some(r) = &a.robot {
        p = p.input_if_file("--robot", r);
    }
    p.output("--out", &a.out)
}

/// `observed-point`.
pub fn observed_point(a: &crate::commands::observed_point::Args) -> FilePlan {
    FilePlan::new()
        .input("DATA", &a.data)
        .output("--out", &a.out)
}

/// `export`.
pub fn export(a: &crate::commands::export::Args) -> FilePlan {
    let mut p = FilePlan::new().input_if_file("MODEL", &a.model);
    if let Some(f) = &a.from {
        p = p.input("--from", f);
    }
    p.output_opt("--urdf", a.urdf.as_deref())
        .output_opt("--mdh-table", a.mdh_table.as_deref())
        .output_opt("--c-header", a.c_header.as_deref())
}
