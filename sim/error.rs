//! The host's error type: every failure a user can cause, each saying what to do about it.

use std::path::PathBuf;

/// What went wrong in the host, phrased for the person who ran it.
#[derive(Debug, thiserror::Error)]
pub enum SimError {
    /// A file the user named does not exist.
    #[error("{what} not found: {path} (check the path; relative paths are taken from the current directory)")]
    MissingFile {
        /// What the file was supposed to be ("world", "controls file").
        what: &'static str,
        /// The path as given.
        path: PathBuf,
    },
    /// MuJoCo refused the MJCF; its own message is kept.
    #[error("MuJoCo could not load {path}: {message}")]
    BadModel {
        /// The MJCF file.
        path: PathBuf,
        /// MuJoCo's message.
        message: String,
    },
    /// A name that the host needs is not in the model.
    #[error("{kind} '{name}' not found in {path}: {hint}")]
    MissingName {
        /// "body", "camera", "actuator", ...
        kind: &'static str,
        /// The name looked up.
        name: String,
        /// The model file.
        path: PathBuf,
        /// What the user should do.
        hint: &'static str,
    },
    /// The episode was complete but its folder could not take it (files a user added while it
    /// ran, or a folder that appeared without `--overwrite`): it was written beside.
    #[error("the episode is in {path}, not in its --out folder")]
    WrittenBeside {
        /// Where the episode is.
        path: PathBuf,
        /// Why the --out folder was left as it was.
        #[source]
        reason: Box<SimError>,
    },
    /// A setting outside the range the host supports.
    #[error("invalid {what}: {detail}")]
    InvalidArgument {
        /// The setting.
        what: &'static str,
        /// Why it is refused and what is allowed.
        detail: String,
    },
    /// The simulation produced NaN/Inf or exploded.
    #[error("simulation became unstable at t = {time:.3} s ({detail}); reduce the timestep or check the model")]
    Unstable {
        /// Simulated time of the failure.
        time: f64,
        /// MuJoCo's warning.
        detail: String,
    },
    /// No EGL display could give us an OpenGL context.
    #[error("no EGL device can render offscreen: {0}. Install Mesa's EGL (libegl-mesa0, libgl1-mesa-dri; scripts/setup.sh does) or an NVIDIA driver")]
    Egl(String),
    /// A malformed controls file or pattern.
    #[error("bad controls {source_name}: {detail}")]
    BadControls {
        /// The file or pattern.
        source_name: String,
        /// What is wrong, with the line.
        detail: String,
    },
    /// Reading or writing a file failed. The OS's reason is the error's source, so a report
    /// of the whole chain (`{:#}`, or [`SimError::chain`]) says it once.
    #[error("{action} {path}")]
    Io {
        /// "cannot write", "cannot read".
        action: &'static str,
        /// The file.
        path: PathBuf,
        /// The OS error.
        source: std::io::Error,
    },
    /// The mapper refused a frame, or writing the map failed.
    #[error("mapping failed: {0}")]
    Mapping(String),
    /// A scene file (OBJ, MTL, texture) that cannot be imported as it is.
    #[error("cannot import {path}: {detail}")]
    BadScene {
        /// The file at fault.
        path: PathBuf,
        /// What is wrong, with the line where there is one.
        detail: String,
    },
    /// A dataset on disk is not what the reader expects.
    #[error("malformed dataset file {path}: {detail}")]
    BadDataset {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        detail: String,
    },
    /// A JSON file splatloop wrote earlier (sweep.json, metrics.json) that does not parse.
    #[error("cannot parse {path}")]
    BadJson {
        /// The file.
        path: PathBuf,
        /// The parser's reason.
        source: serde_json::Error,
    },
    /// A rerun of a sweep with settings other than its sweep.json's.
    #[error("{path} holds a sweep with other settings ({detail}); rerun with the same settings to resume it, or use a new --out")]
    SweepChanged {
        /// The sweep.json.
        path: PathBuf,
        /// The first setting that differs.
        detail: String,
    },
    /// An episode of a sweep that cannot run yet or cannot be run by this backend.
    #[error("episode {index} of the sweep: {detail}")]
    SweepEpisode {
        /// Its index in the sweep's order.
        index: usize,
        /// Why not, and what to do.
        detail: String,
    },
    /// The rerun recording failed (a file that cannot be written, a viewer address that does
    /// not parse); the SDK's error is kept.
    #[error("rerun recording: {what} (check the --rerun path or the --rerun-connect address)")]
    Rerun {
        /// What was being done.
        what: &'static str,
        /// The SDK's error.
        #[source]
        source: Box<dyn std::error::Error + Send + Sync>,
    },
}

/// Shorthand for host results.
pub type Result<T, E = SimError> = std::result::Result<T, E>;

impl SimError {
    /// The error and every cause under it, joined by ": ", for texts that outlive the error
    /// (metrics.json's `ended`).
    pub fn chain(&self) -> String {
        let mut text = self.to_string();
        let mut cause = std::error::Error::source(self);
        while let Some(c) = cause {
            text.push_str(": ");
            text.push_str(&c.to_string());
            cause = c.source();
        }
        text
    }

    /// Wraps an I/O error with the file it concerns.
    pub fn io(action: &'static str, path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        SimError::Io {
            action,
            path: path.into(),
            source,
        }
    }
}
