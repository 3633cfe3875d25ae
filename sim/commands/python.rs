//! The Python side of the command line: which interpreter holds the Python package (Ray
//! sweeps and `--planner python:...` need it), and handing a Python planner's episode to it.

use crate::episode::PythonPlannerSpec;
use anyhow::{Context, Result};
use std::path::{Path, PathBuf};

/// The variable that names the Python to use.
pub const PYTHON_VARIABLE: &str = "SPLATLOOP_PYTHON";

/// The Python that the package and Ray are installed for: `SPLATLOOP_PYTHON`, else the
/// checkout's .venv (scripts/setup.sh makes it), found from the working folder or from the
/// binary's place in target/, else python3.
pub fn default_python(binary: &Path) -> PathBuf {
    if let Some(python) = std::env::var_os(PYTHON_VARIABLE).filter(|p| !p.is_empty()) {
        return PathBuf::from(python);
    }
    let venv = |root: &Path| root.join(".venv/bin/python");
    let candidates = std::iter::once(PathBuf::from("."))
        .chain(binary.ancestors().skip(1).take(4).map(PathBuf::from));
    for root in candidates {
        if venv(&root).exists() {
            return venv(&root);
        }
    }
    PathBuf::from("python3")
}

/// What the interpreter runs: the package's command line, or a clear error when the package
/// is not there.
const BOOTSTRAP: &str = r#"import sys
try:
    from splatloop.cli import main
except ImportError as error:
    sys.exit(f"error: --planner python:... runs in the Python package splatloop, which {sys.executable} cannot import ({error}); scripts/setup.sh installs it into .venv, or set SPLATLOOP_PYTHON to a python that has it")
sys.exit(main(sys.argv[1:]))
"#;

/// Runs this process's `splatloop run ...` in the Python package's interpreter instead (the
/// same words; the package holds the same episode code), replacing this process so that
/// signals and the exit code are the episode's own. Returns only on failure.
pub fn run_in_python(spec: &PythonPlannerSpec) -> Result<Option<u8>> {
    use std::os::unix::process::CommandExt;
    let binary = std::env::current_exe().context("cannot find the splatloop binary")?;
    let python = default_python(&binary);
    // The words after the subcommand, as typed.
    let words: Vec<std::ffi::OsString> = std::env::args_os()
        .skip(1)
        .skip_while(|w| w != "run")
        .collect();
    let error = std::process::Command::new(&python)
        .arg("-c")
        .arg(BOOTSTRAP)
        .args(&words)
        .exec();
    Err(error).with_context(|| {
        format!(
            "cannot start {} for the Python planner python:{}:{} (set {PYTHON_VARIABLE} to a python with the package splatloop)",
            python.display(),
            spec.module,
            spec.class
        )
    })
}
