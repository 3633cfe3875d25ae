//! A headless OpenGL context through EGL: no display server, no window.
//!
//! Order of preference: EGL devices (real GPUs first, Mesa's software device last), then
//! Mesa's surfaceless platform (llvmpipe). `SPLATLOOP_EGL_DEVICE=N` (or MuJoCo's
//! `MUJOCO_EGL_DEVICE_ID`) picks one device; `SPLATLOOP_EGL_PLATFORM=device|surfaceless`
//! forces a platform. The chosen one is logged at info level.

#[allow(
    non_upper_case_globals,
    non_camel_case_types,
    non_snake_case,
    dead_code,
    unused_imports,
    missing_docs,
    clippy::all
)]
mod sys {
    include!(concat!(env!("OUT_DIR"), "/egl_bindings.rs"));
}

use crate::error::{Result, SimError};
use std::ffi::{c_void, CStr};
use std::ptr;

/// Which EGL platform to use.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum EglPlatform {
    /// Devices first, then surfaceless.
    #[default]
    Auto,
    /// Only EGL devices (`EGL_EXT_platform_device`).
    Device,
    /// Only Mesa's surfaceless platform (`EGL_MESA_platform_surfaceless`).
    Surfaceless,
}

impl EglPlatform {
    /// Reads `SPLATLOOP_EGL_PLATFORM`; unset means [`EglPlatform::Auto`].
    pub fn from_env() -> Result<Self> {
        match std::env::var("SPLATLOOP_EGL_PLATFORM").as_deref() {
            Err(_) | Ok("") | Ok("auto") => Ok(EglPlatform::Auto),
            Ok("device") => Ok(EglPlatform::Device),
            Ok("surfaceless") => Ok(EglPlatform::Surfaceless),
            Ok(other) => Err(SimError::InvalidArgument {
                what: "SPLATLOOP_EGL_PLATFORM",
                detail: format!("'{other}' is not one of auto, device, surfaceless"),
            }),
        }
    }
}

/// Which platform and device to try; [`EglOptions::from_env`] reads the environment.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct EglOptions {
    /// Platform order.
    pub platform: EglPlatform,
    /// Only this EGL device index (device platform).
    pub device: Option<usize>,
}

impl EglOptions {
    /// `SPLATLOOP_EGL_PLATFORM` and `SPLATLOOP_EGL_DEVICE` (or `MUJOCO_EGL_DEVICE_ID`).
    pub fn from_env() -> Result<Self> {
        let device = match std::env::var("SPLATLOOP_EGL_DEVICE")
            .or_else(|_| std::env::var("MUJOCO_EGL_DEVICE_ID"))
        {
            Ok(text) if !text.trim().is_empty() => {
                Some(text.trim().parse().map_err(|_| SimError::InvalidArgument {
                    what: "SPLATLOOP_EGL_DEVICE",
                    detail: format!("'{text}' is not a device index"),
                })?)
            }
            _ => None,
        };
        Ok(EglOptions {
            platform: EglPlatform::from_env()?,
            device,
        })
    }
}

/// An OpenGL (compatibility profile) context, current on the thread that made it.
///
/// Not `Send`: a GL context belongs to one thread.
pub struct EglContext {
    display: sys::EGLDisplay,
    context: sys::EGLContext,
    description: String,
}

impl Drop for EglContext {
    fn drop(&mut self) {
        // SAFETY: display and context were created by us; releasing and destroying the context
        // is valid on the thread where it is current. The display is not terminated because
        // EGL shares it with other contexts of the process.
        unsafe {
            sys::eglMakeCurrent(
                self.display,
                ptr::null_mut(),
                ptr::null_mut(),
                ptr::null_mut(),
            );
            sys::eglDestroyContext(self.display, self.context);
        }
    }
}

type QueryDevices = unsafe extern "C" fn(i32, *mut sys::EGLDeviceEXT, *mut i32) -> u32;
type QueryDeviceString = unsafe extern "C" fn(sys::EGLDeviceEXT, i32) -> *const i8;
type GetPlatformDisplay = unsafe extern "C" fn(u32, *mut c_void, *const i32) -> sys::EGLDisplay;
type GetGlString = unsafe extern "C" fn(u32) -> *const u8;

const GL_VENDOR: u32 = 0x1F00;
const GL_RENDERER: u32 = 0x1F01;
const GL_VERSION: u32 = 0x1F02;

impl EglContext {
    /// Makes a context with the platform order of [`EglPlatform::from_env`].
    pub fn new() -> Result<Self> {
        Self::with_options(EglOptions::from_env()?)
    }

    /// Makes a context with `options`, trying candidates in order; the error lists why each
    /// one failed.
    pub fn with_options(options: EglOptions) -> Result<Self> {
        let platform = options.platform;
        let mut failures = Vec::new();
        let get_platform_display: Option<GetPlatformDisplay> = load("eglGetPlatformDisplayEXT");
        let Some(get_platform_display) = get_platform_display else {
            return Err(SimError::Egl(
                "libEGL lacks eglGetPlatformDisplayEXT (EGL_EXT_platform_base)".into(),
            ));
        };
        if platform != EglPlatform::Surfaceless {
            match devices(options.device) {
                Ok(devices) => {
                    for (index, device, name) in devices {
                        // SAFETY: the device handle came from eglQueryDevicesEXT.
                        let display = unsafe {
                            get_platform_display(sys::EGL_PLATFORM_DEVICE_EXT, device, ptr::null())
                        };
                        match Self::on_display(display, format!("EGL device {index} ({name})")) {
                            Ok(context) => return Ok(context),
                            Err(why) => failures.push(format!("device {index} ({name}): {why}")),
                        }
                    }
                }
                Err(why) => failures.push(why),
            }
        }
        if platform != EglPlatform::Device {
            // SAFETY: EGL_DEFAULT_DISPLAY (null) is the documented native display here.
            let display = unsafe {
                get_platform_display(
                    sys::EGL_PLATFORM_SURFACELESS_MESA,
                    ptr::null_mut(),
                    ptr::null(),
                )
            };
            match Self::on_display(display, "Mesa surfaceless".into()) {
                Ok(context) => return Ok(context),
                Err(why) => failures.push(format!("surfaceless: {why}")),
            }
        }
        Err(SimError::Egl(if failures.is_empty() {
            "no EGL candidates".into()
        } else {
            failures.join("; ")
        }))
    }

    fn on_display(display: sys::EGLDisplay, label: String) -> Result<Self, String> {
        if display.is_null() {
            return Err(format!("no display ({})", egl_error()));
        }
        // SAFETY: display is a valid EGLDisplay handle; all out-pointers point at locals.
        unsafe {
            let (mut major, mut minor) = (0, 0);
            if sys::eglInitialize(display, &mut major, &mut minor) == 0 {
                return Err(format!("eglInitialize failed ({})", egl_error()));
            }
            if sys::eglBindAPI(sys::EGL_OPENGL_API) == 0 {
                return Err(format!("no desktop OpenGL ({})", egl_error()));
            }
            let config = choose_config(display)?;
            let context = sys::eglCreateContext(display, config, ptr::null_mut(), ptr::null());
            if context.is_null() {
                return Err(format!("eglCreateContext failed ({})", egl_error()));
            }
            if sys::eglMakeCurrent(display, ptr::null_mut(), ptr::null_mut(), context) == 0 {
                sys::eglDestroyContext(display, context);
                return Err(format!(
                    "eglMakeCurrent without a surface failed ({})",
                    egl_error()
                ));
            }
            let description = format!("{label}: {}", gl_renderer());
            tracing::info!("rendering with {description}");
            Ok(EglContext {
                display,
                context,
                description,
            })
        }
    }

    /// This context's `glFlush`: hands the drawing queued so far to the renderer without
    /// waiting for it, so a software rasteriser draws while the host works on.
    pub fn gl_flush(&self) -> Option<GlFlush> {
        load::<GlFlush>("glFlush")
    }

    /// Which platform/device and GL renderer this context uses, for logs and benchmarks.
    pub fn description(&self) -> &str {
        &self.description
    }

    /// Whether the renderer is a software rasteriser (llvmpipe/softpipe/swrast).
    pub fn is_software(&self) -> bool {
        let d = self.description.to_ascii_lowercase();
        d.contains("llvmpipe") || d.contains("softpipe") || d.contains("swrast")
    }
}

/// EGL devices, hardware first, Mesa's software device last; `only` keeps one index.
fn devices(only: Option<usize>) -> Result<Vec<(usize, sys::EGLDeviceEXT, String)>, String> {
    let query_devices: QueryDevices =
        load("eglQueryDevicesEXT").ok_or("libEGL lacks eglQueryDevicesEXT")?;
    let query_string: Option<QueryDeviceString> = load("eglQueryDeviceStringEXT");
    let mut handles = [ptr::null_mut(); 16];
    let mut count = 0;
    // SAFETY: the array holds 16 handles and EGL writes at most that many.
    if unsafe { query_devices(handles.len() as i32, handles.as_mut_ptr(), &mut count) } == 0 {
        return Err(format!("eglQueryDevicesEXT failed ({})", egl_error()));
    }
    let mut devices: Vec<_> = handles[..count.max(0) as usize]
        .iter()
        .enumerate()
        .map(|(index, &device)| {
            let extensions = query_string
                // SAFETY: device is a handle from eglQueryDevicesEXT; EGL returns a static
                // NUL-terminated string or null.
                .map(|q| unsafe { q(device, sys::EGL_EXTENSIONS as i32) })
                .filter(|s| !s.is_null())
                // SAFETY: non-null strings from EGL are NUL-terminated.
                .map(|s| unsafe { CStr::from_ptr(s) }.to_string_lossy().into_owned())
                .unwrap_or_default();
            let software = extensions.contains("EGL_MESA_device_software");
            let name = if software { "software" } else { "hardware" };
            (index, device, name.to_owned())
        })
        .collect();
    if let Some(index) = only {
        devices.retain(|(i, _, _)| *i == index);
        if devices.is_empty() {
            return Err(format!(
                "EGL device {index} was requested but only {count} EGL devices exist"
            ));
        }
    }
    devices.sort_by_key(|(_, _, name)| name == "software");
    Ok(devices)
}

unsafe fn choose_config(display: sys::EGLDisplay) -> Result<sys::EGLConfig, String> {
    // Pbuffer-capable configs first (NVIDIA), then any config (Mesa surfaceless has none).
    for surface_type in [sys::EGL_PBUFFER_BIT as i32, 0] {
        let attributes = [
            sys::EGL_SURFACE_TYPE as i32,
            surface_type,
            sys::EGL_RENDERABLE_TYPE as i32,
            sys::EGL_OPENGL_BIT as i32,
            sys::EGL_RED_SIZE as i32,
            8,
            sys::EGL_GREEN_SIZE as i32,
            8,
            sys::EGL_BLUE_SIZE as i32,
            8,
            sys::EGL_DEPTH_SIZE as i32,
            24,
            sys::EGL_NONE as i32,
        ];
        let mut config = ptr::null_mut();
        let mut found = 0;
        // SAFETY: attributes is EGL_NONE-terminated; config/found point at locals.
        let ok = unsafe {
            sys::eglChooseConfig(display, attributes.as_ptr(), &mut config, 1, &mut found)
        };
        if ok != 0 && found > 0 {
            return Ok(config);
        }
    }
    Err(format!("no RGB8/depth24 OpenGL config ({})", egl_error()))
}

/// OpenGL's `glFlush`.
pub type GlFlush = unsafe extern "C" fn();

/// Loads an EGL extension (or, as Mesa and NVIDIA allow, core GL) function by name.
fn load<F: Copy>(name: &str) -> Option<F> {
    assert_eq!(
        std::mem::size_of::<F>(),
        std::mem::size_of::<*const c_void>()
    );
    let c_name = std::ffi::CString::new(name).ok()?;
    // SAFETY: eglGetProcAddress takes a NUL-terminated name and returns a function pointer or
    // null; F is a function pointer type of the same size (asserted above) whose signature
    // the callers match to the extension's specification.
    unsafe {
        let address = sys::eglGetProcAddress(c_name.as_ptr());
        address.map(|f| std::mem::transmute_copy::<_, F>(&f))
    }
}

fn gl_renderer() -> String {
    let Some(get_string) = load::<GetGlString>("glGetString") else {
        return "unknown renderer".into();
    };
    let read = |name| {
        // SAFETY: a context is current; glGetString returns a static string or null.
        let s = unsafe { get_string(name) };
        if s.is_null() {
            String::from("?")
        } else {
            // SAFETY: non-null GL strings are NUL-terminated.
            unsafe { CStr::from_ptr(s.cast()) }
                .to_string_lossy()
                .into_owned()
        }
    };
    format!(
        "{} / {} / {}",
        read(GL_VENDOR),
        read(GL_RENDERER),
        read(GL_VERSION)
    )
}

fn egl_error() -> String {
    // SAFETY: eglGetError has no preconditions.
    let code = unsafe { sys::eglGetError() };
    format!("EGL error 0x{code:04x}")
}
