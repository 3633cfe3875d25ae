//! Generates the MuJoCo and EGL bindings with bindgen and links libmujoco and libEGL.
//!
//! MuJoCo comes from Debian's `libmujoco-dev` (headers in /usr/include/mujoco, no pkg-config
//! file) unless `MUJOCO_DIR` points at another MuJoCo: `include/mujoco/mujoco.h` with
//! `lib/libmujoco.so`, or a pip wheel's `site-packages/mujoco` (the headers beside a versioned
//! `libmujoco.so.X.Y.Z`). The header's version turns on the cfgs the FFI module uses.

use std::env;
use std::path::{Path, PathBuf};

const SETUP_HINT: &str =
    "run `bash scripts/setup.sh` (it installs libmujoco-dev, libclang-dev and libegl-dev), \
     or set MUJOCO_DIR to a MuJoCo with include/mujoco/mujoco.h and libmujoco.so in lib/ or \
     beside include/ (a pip wheel's folder: \
     MUJOCO_DIR=$(python3 -c 'import mujoco, os; print(os.path.dirname(mujoco.__file__))'))";

fn main() {
    println!("cargo:rerun-if-env-changed=MUJOCO_DIR");
    println!("cargo:rerun-if-env-changed=LIBCLANG_PATH");
    println!("cargo:rerun-if-changed=build.rs");
    emit_build_commit();

    // Where MuJoCo's headers and library live: Debian's, an include/ + lib/ install, or a pip
    // wheel's folder (site-packages/mujoco: include/ and libmujoco.so.X.Y.Z side by side).
    let (include_dir, library) = match env::var_os("MUJOCO_DIR") {
        Some(dir) => {
            let dir = PathBuf::from(dir);
            let library = find_library(&dir);
            (dir.join("include"), Some(library))
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
    let version = header_version(&mujoco_header);
    // The API changes the FFI module handles, by the version that made them (major * 100 +
    // minor * 10 + patch, as mjVERSION_HEADER counted before 4.0).
    for (threshold, name) in MUJOCO_CHANGES {
        println!("cargo::rustc-check-cfg=cfg({name})");
        if version >= *threshold {
            println!("cargo:rustc-cfg={name}");
        }
    }
    println!(
        "cargo:rustc-env=SPLATLOOP_MUJOCO_HEADER={}.{}.{}",
        version / 100,
        version / 10 % 10,
        version % 10
    );
    let egl_header = Path::new("/usr/include/EGL/egl.h");
    if !egl_header.is_file() {
        fail(&format!(
            "EGL headers not found at {}; {SETUP_HINT}",
            egl_header.display()
        ));
    }

    // Link the libraries.
    match &library {
        Some((lib_dir, name)) => {
            println!("cargo:rustc-link-search=native={}", lib_dir.display());
            // A MuJoCo outside the system paths must also be found at run time.
            println!("cargo:rustc-link-arg=-Wl,-rpath,{}", lib_dir.display());
            match name {
                Some(file) => println!("cargo:rustc-link-lib=dylib:+verbatim={file}"),
                None => println!("cargo:rustc-link-lib=dylib=mujoco"),
            }
        }
        None => println!("cargo:rustc-link-lib=dylib=mujoco"),
    }
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

/// MuJoCo API changes behind cfgs: (first version, cfg name).
const MUJOCO_CHANGES: &[(u32, &str)] = &[
    // mj_ray's flg_static became an mjtBool and it gained a normal output; model sizes became
    // 64-bit (mjtSize).
    (300, "mujoco_3"),
    (400, "mujoco_4"),
];

/// The folder that holds libmujoco and, for a versioned file only (a pip wheel ships
/// `libmujoco.so.3.3.7` and no unversioned link), its file name to link verbatim.
fn find_library(dir: &Path) -> (PathBuf, Option<String>) {
    for folder in [dir.join("lib"), dir.to_path_buf()] {
        if folder.join("libmujoco.so").exists() {
            return (folder, None);
        }
        let versioned = std::fs::read_dir(&folder).ok().and_then(|entries| {
            entries
                .filter_map(|e| e.ok())
                .map(|e| e.file_name().to_string_lossy().into_owned())
                .filter(|n| n.starts_with("libmujoco.so."))
                .max()
        });
        if let Some(file) = versioned {
            return (folder, Some(file));
        }
    }
    fail(&format!(
        "no libmujoco.so under {} (looked in lib/ and the folder itself); {SETUP_HINT}",
        dir.display()
    ))
}

/// mjVERSION_HEADER as major * 100 + minor * 10 + patch (4.0 counts major * 1e6 + minor * 1e3 +
/// patch).
fn header_version(header: &Path) -> u32 {
    let text = std::fs::read_to_string(header)
        .unwrap_or_else(|e| fail(&format!("cannot read {}: {e}", header.display())));
    let value = text
        .lines()
        .find_map(|l| l.trim().strip_prefix("#define mjVERSION_HEADER"))
        .and_then(|v| v.trim().parse::<u32>().ok())
        .unwrap_or_else(|| fail(&format!("no mjVERSION_HEADER in {}", header.display())));
    if value >= 1_000_000 {
        let (major, minor, patch) = (value / 1_000_000, value / 1000 % 1000, value % 1000);
        major * 100 + minor.min(9) * 10 + patch.min(9)
    } else {
        value
    }
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

/// The commit checked out when the binary is built, as `SPLATLOOP_COMMIT` for episode.json
/// ("unknown" outside a git checkout). Rebuilt when HEAD or its branch moves; uncommitted
/// edits are not marked (watching every source would rerun bindgen on each edit).
fn emit_build_commit() {
    let git = |args: &[&str]| {
        std::process::Command::new("git")
            .args(args)
            .output()
            .ok()
            .filter(|o| o.status.success())
            .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_owned())
    };
    let commit = git(&["rev-parse", "HEAD"]).unwrap_or_else(|| "unknown".into());
    println!("cargo:rustc-env=SPLATLOOP_COMMIT={commit}");
    let branch = git(&["symbolic-ref", "-q", "HEAD"]);
    for name in ["HEAD", "packed-refs"]
        .into_iter()
        .map(str::to_owned)
        .chain(branch)
    {
        if let Some(path) = git(&["rev-parse", "--git-path", &name]) {
            println!("cargo:rerun-if-changed={path}");
        }
    }
}
