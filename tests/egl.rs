//! Both headless EGL platforms render the same picture; a request nothing can meet fails
//! with a message.

use crate::support::room;
use splatloop::camera::SensorConfig;
use splatloop::egl::{EglContext, EglOptions, EglPlatform};

fn depth_with(platform: EglPlatform) -> (String, Vec<f32>) {
    let gl = EglContext::with_options(EglOptions {
        platform,
        device: None,
    })
    .expect("context");
    let world = room();
    let mut camera = world
        .make_camera(&SensorConfig::default(), 0, &gl)
        .expect("camera");
    let frame = camera.capture(world.data()).expect("frame");
    (gl.description().to_owned(), frame.depth)
}

#[test]
fn device_and_surfaceless_platforms_render_the_same_depth() {
    let (device_name, device_depth) = depth_with(EglPlatform::Device);
    let (surfaceless_name, surfaceless_depth) = depth_with(EglPlatform::Surfaceless);
    assert!(device_name.starts_with("EGL device"), "{device_name}");
    assert!(
        surfaceless_name.starts_with("Mesa surfaceless"),
        "{surfaceless_name}"
    );
    let differing = device_depth
        .iter()
        .zip(&surfaceless_depth)
        .filter(|(a, b)| (*a - *b).abs() > 1e-3)
        .count();
    assert!(device_depth.iter().filter(|d| **d > 0.0).count() > 1000);
    assert!(
        differing * 100 < device_depth.len(),
        "{differing} pixels differ"
    );
}

#[test]
fn a_missing_device_is_a_clear_error() {
    let error = EglContext::with_options(EglOptions {
        platform: EglPlatform::Device,
        device: Some(99),
    })
    .err()
    .expect("there is no EGL device 99");
    let text = error.to_string();
    assert!(text.contains("EGL device 99 was requested"), "{text}");
    assert!(text.contains("Install Mesa's EGL"), "{text}");
}

/// MuJoCo's OpenGL loader (glad, run by `mjr_makeContext`) keeps its extension list in C
/// globals that each call allocates and frees; cameras made on several threads at once (tests,
/// a library user's parallel episodes) used to race there and crash the process (SIGSEGV in CI).
/// Every camera made here, all threads starting together, renders the same depth as one made
/// alone.
#[test]
fn cameras_made_on_many_threads_at_once_render_like_one_made_alone() {
    let (_, alone) = depth_with(EglPlatform::Surfaceless);
    let threads = 8;
    let start = std::sync::Barrier::new(threads);
    let depths: Vec<Vec<f32>> = std::thread::scope(|scope| {
        let workers: Vec<_> = (0..threads)
            .map(|_| {
                scope.spawn(|| {
                    let world = room();
                    let gl = EglContext::with_options(EglOptions {
                        platform: EglPlatform::Surfaceless,
                        device: None,
                    })
                    .expect("context");
                    let mut last = Vec::new();
                    for _ in 0..10 {
                        start.wait();
                        let mut camera = world
                            .make_camera(&SensorConfig::default(), 0, &gl)
                            .expect("camera");
                        last = camera.capture(world.data()).expect("frame").depth;
                    }
                    last
                })
            })
            .collect();
        workers
            .into_iter()
            .map(|w| w.join().expect("thread"))
            .collect()
    });
    for depth in depths {
        assert_eq!(depth, alone);
    }
}
