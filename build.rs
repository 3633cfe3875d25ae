//! Generates the MuJoCo and EGL bindings with bindgen and links libmujoco and libEGL.
//!
//! MuJoCo comes from Debian's `libmujoco-dev` (headers in /usr/include/mujoco, no pkg-config
//! file) unless `MUJOCO_DIR` points at another MuJoCo with `include/mujoco/mujoco.h` and
//! `lib/libmujoco.so`.

use std::env;
use std::path::{Path, PathBuf};

const SETUP_HINT: &str =
    "run `bash scripts/setup.sh` (it installs libmujoco-dev, libclang-dev and libegl-dev), \
     or set MUJOCO_DIR to a MuJoCo with include/mujoco/mujoco.h and lib/libmujoco.so";

fn main() {
    println!("cargo:rerun-if-env-changed=MUJOCO_DIR");
    println!("cargo:rerun-if-env-changed=LIBCLANG_PATH");
    println!("cargo:rerun-if-changed=build.rs");

    // Where MuJoCo's headers and library live.
    let (include_dir, lib_dir) = match env::var_os("MUJOCO_DIR") {
        Some(dir) => {
            let dir = PathBuf::from(dir);
            (dir.join("include"), Some(dir.join("lib")))
        }
        None => (PathBuf::from("/usr/include"), None),
    };
    let mujoco_header = include_dir.join("mujoco").join("mujoco.h");
    if !mujoco_header.is_file() {
        fail(&format!(
            "MuJoCo headers not found at {}; {SETUP_HINT}",
            mujoco_header.display()
        ));
    }
    let egl_header = Path::new("/usr/include/EGL/egl.h");
    if !egl_header.is_file() {
        fail(&format!(
            "EGL headers not found at {}; {SETUP_HINT}",
            egl_header.display()
        ));
    }

    // Link the libraries.
    if let Some(lib_dir) = &lib_dir {
        println!("cargo:rustc-link-search=native={}", lib_dir.display());
        // A MuJoCo outside the system paths must also be found at run time.
        println!("cargo:rustc-link-arg=-Wl,-rpath,{}", lib_dir.display());
    }
    println!("cargo:rustc-link-lib=dylib=mujoco");
    println!("cargo:rustc-link-lib=dylib=EGL");

    let out_dir = PathBuf::from(env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
    generate(
        bindgen::Builder::default()
            .header(mujoco_header.to_string_lossy())
            .clang_arg(format!("-I{}", include_dir.display()))
            .allowlist_function("mj[a-z]?_.*")
            .allowlist_type("mj.*")
            .allowlist_var("mj.*")
            .rustified_enum("mjt.*"),
        &out_dir.join("mujoco_bindings.rs"),
    );
    generate(
        bindgen::Builder::default()
            .header_contents(
                "egl_all.h",
                "#include <EGL/egl.h>\n#include <EGL/eglext.h>\n",
            )
            .allowlist_function("egl.*")
            .allowlist_type("EGL.*|PFNEGL.*")
            .allowlist_var("EGL_.*"),
        &out_dir.join("egl_bindings.rs"),
    );
}

/// Runs bindgen, turning its panics (libclang missing) into a message that says what to install.
fn generate(builder: bindgen::Builder, out: &Path) {
    let builder = builder
        .layout_tests(false)
        .derive_default(true)
        .parse_callbacks(Box::new(bindgen::CargoCallbacks::new()));
    let generated = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| builder.generate()));
    match generated {
        Ok(Ok(bindings)) => {
            if let Err(e) = bindings.write_to_file(out) {
                fail(&format!("cannot write {}: {e}", out.display()));
            }
        }
        Ok(Err(e)) => fail(&format!("bindgen failed: {e}; {SETUP_HINT}")),
        Err(_) => fail(&format!(
            "bindgen could not run libclang (is libclang-dev installed? LIBCLANG_PATH may point at it); {SETUP_HINT}"
        )),
    }
}

fn fail(message: &str) -> ! {
    eprintln!("error: {message}");
    println!("cargo:warning={message}");
    std::process::exit(1);
}
