//! The one place that talks to MuJoCo's C API; everything outside sees safe types.
//!
//! Mirrors MuJoCo's layers: [`Model`] and [`Data`] (`mj_`), [`SceneRenderer`] (`mjv_` + `mjr_`).
//! Indices are checked here before they reach C, so a bad name or id is a Rust error, not a
//! C abort. MuJoCo's error and warning hooks are routed into `tracing`.

#[allow(
    non_upper_case_globals,
    non_camel_case_types,
    non_snake_case,
    dead_code,
    unused_imports,
    missing_docs,
    clippy::all
)]
pub(crate) mod sys {
    include!(concat!(env!("OUT_DIR"), "/mujoco_bindings.rs"));
}

mod data;
mod model;
mod render;

pub use data::{Contact, Data, RayHit};
pub use model::{GeomType, MaterialInfo, Model, ObjKind, Shape, TextureInfo};
pub use render::{RenderFlags, SceneRenderer};

use std::ffi::CStr;
use std::os::raw::c_char;
use std::sync::Once;

/// The MuJoCo version whose headers the bindings were generated from (build.rs reads
/// mjVERSION_HEADER); the library loaded at run time must be the same one.
pub const HEADER_VERSION: &str = env!("SPLATLOOP_MUJOCO_HEADER");

/// MuJoCo's version as it reports itself, for episode metadata.
pub fn version() -> String {
    // SAFETY: mj_versionString returns a pointer to a static NUL-terminated string.
    let raw = unsafe { CStr::from_ptr(sys::mj_versionString()) };
    raw.to_string_lossy().into_owned()
}

/// Routes MuJoCo's error and warning callbacks into our logs. Idempotent.
///
/// MuJoCo's hooks are process-wide C globals, so this is the one piece of global state we
/// cannot avoid; it is set once and never changes.
pub fn install_log_hooks() {
    static HOOKS: Once = Once::new();
    HOOKS.call_once(|| {
        // SAFETY: the hooks are plain function pointers written once, before any other MuJoCo
        // call of ours, and the functions they point to live for the whole process.
        unsafe {
            sys::mju_user_error = Some(on_mujoco_error);
            sys::mju_user_warning = Some(on_mujoco_warning);
        }
    });
}

/// MuJoCo calls this on an unrecoverable error; its state is undefined after it, so we log the
/// message loudly and exit instead of letting C continue or abort without a word.
extern "C" fn on_mujoco_error(message: *const c_char) {
    let text = c_message(message);
    tracing::error!("MuJoCo error: {text}");
    eprintln!("splatloop: MuJoCo reported a fatal error and cannot continue: {text}");
    std::process::exit(70);
}

extern "C" fn on_mujoco_warning(message: *const c_char) {
    tracing::warn!("MuJoCo: {}", c_message(message));
}

fn c_message(message: *const c_char) -> String {
    if message.is_null() {
        return String::from("(no message)");
    }
    // SAFETY: MuJoCo passes a NUL-terminated buffer that is valid for the call.
    unsafe { CStr::from_ptr(message) }
        .to_string_lossy()
        .trim()
        .to_owned()
}
