//! A rerun recording of an episode (`--rerun FILE.rrd`, `--rerun-connect ADDR`): what robotics
//! users open to look at a run. Everything is logged on the `sim_time` timeline (simulated
//! seconds), in the world frame (z up):
//!
//! - `world/camera` — the pinhole camera at world_from_camera (OpenCV optical frame), with its
//!   `rgb` image, `depth` image (metres, as the dataset's depth PNGs: 5000 per metre) and, with
//!   masks, its `instance` and `semantic` segmentation images (annotated with labels.json's
//!   instance and class names);
//! - `world/robot/path` — the base's path so far, a line strip;
//! - `world/plan/candidates` and `world/plan/chosen` — every planning step's candidate
//!   trajectories and the one followed;
//! - `world/map/colour` and `world/map/uncertainty` — the Gaussian map as points (their
//!   colours; their uncertainty on trajectory.png's blue-to-red ramp), every `map_every`
//!   mapping steps;
//! - `metrics/coverage`, `metrics/gaussians` and `timing/{camera,mapping,planning}_ms` scalars.
//!
//! The SDK is a large dependency, so it sits behind the `rerun` cargo feature (scripts/setup.sh
//! builds with it); without it, asking for a recording is an error that says how to get one.

use crate::error::{Result, SimError};
use crate::labels::Labels;
use crate::robot::Pose2;
use autonomy::camera::PinholeCamera;
use autonomy::map::GaussianMap;
use std::path::{Path, PathBuf};

/// Depth units per metre in the recording (the dataset's depth PNG scale, DESIGN.md's).
pub const DEPTH_PER_METRE: f32 = 5000.0;

/// The error of a recording asked of a build without the SDK.
fn not_built() -> SimError {
    SimError::InvalidArgument {
        what: "--rerun / --rerun-connect",
        detail:
            "this splatloop was built without rerun recordings; build it with \
                 `bash scripts/setup.sh --with-rerun` (or `cargo build --release --features rerun`)"
                .into(),
    }
}

/// Where a recording goes and how much of the map it holds.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RerunTarget {
    /// An .rrd file to write (must not exist unless the episode may overwrite).
    pub file: Option<PathBuf>,
    /// A running viewer to stream to (`rerun` prints its address; host:port is enough).
    pub connect: Option<String>,
    /// Log the map every this many mapping steps (1: every step).
    pub map_every: usize,
}

impl RerunTarget {
    /// Whether anything is to be recorded.
    pub fn wanted(&self) -> bool {
        self.file.is_some() || self.connect.is_some()
    }

    /// Refuses a recording that cannot be made before the episode starts: `map_every` 0, a
    /// file inside the episode folder `out` (which is replaced as a whole when the episode is
    /// written), or an existing file without `overwrite`.
    pub fn check(&self, out: &Path, overwrite: bool) -> Result<()> {
        if !self.wanted() {
            return Ok(());
        }
        if cfg!(not(feature = "rerun")) {
            return Err(not_built());
        }
        if self.map_every == 0 {
            return Err(SimError::InvalidArgument {
                what: "--rerun-map-every",
                detail: "0; give 1 (every mapping step) or more".into(),
            });
        }
        if let Some(address) = &self.connect {
            reach_viewer(address)?;
        }
        let Some(file) = &self.file else {
            return Ok(());
        };
        let inside = match (std::path::absolute(file), std::path::absolute(out)) {
            (Ok(file), Ok(out)) => file.starts_with(out),
            _ => false,
        };
        if inside {
            return Err(SimError::InvalidArgument {
                what: "--rerun",
                detail: format!(
                    "{} is inside the episode folder {}, which is replaced when the episode is \
                     written; put the recording beside it",
                    file.display(),
                    out.display()
                ),
            });
        }
        if file.exists() && !overwrite {
            return Err(SimError::InvalidArgument {
                what: "--rerun",
                detail: format!(
                    "{} exists; name a new file, or pass --overwrite to replace it",
                    file.display()
                ),
            });
        }
        Ok(())
    }
}

/// Refuses a viewer address nothing answers at, before an episode is run for it: the SDK
/// only finds out when the recording is flushed at the end.
fn reach_viewer(address: &str) -> Result<()> {
    use std::net::{TcpStream, ToSocketAddrs};
    let url = viewer_url(address);
    let host_port = url
        .split_once("://")
        .map_or(url.as_str(), |(_, rest)| rest)
        .split('/')
        .next()
        .unwrap_or_default();
    let refuse = |why: String| {
        SimError::InvalidArgument {
        what: "--rerun-connect",
        detail: format!(
            "no rerun viewer answers at {address} ({why}); start one with `rerun` (it prints its address) or drop --rerun-connect"
        ),
    }
    };
    let targets: Vec<_> = host_port
        .to_socket_addrs()
        .map_err(|e| refuse(e.to_string()))?
        .collect();
    let mut last = String::from("the name resolves to no address");
    for target in targets {
        match TcpStream::connect_timeout(&target, std::time::Duration::from_secs(3)) {
            Ok(_) => return Ok(()),
            Err(e) => last = e.to_string(),
        }
    }
    Err(refuse(last))
}

/// The gRPC address a viewer listens on, from what a person types: a full
/// `rerun+http://HOST:PORT/proxy` URL as it is, else `HOST:PORT` completed to one.
pub fn viewer_url(address: &str) -> String {
    if address.contains("://") {
        address.to_string()
    } else {
        format!("rerun+http://{address}/proxy")
    }
}

/// The colour of an uncertainty on trajectory.png's ramp: blue at or below `low`, red at or
/// above `high`, through green and yellow; grey when the map has no spread to show.
pub fn uncertainty_colour(value: f32, low: f32, high: f32) -> [u8; 3] {
    if high.partial_cmp(&low) != Some(std::cmp::Ordering::Greater) || !value.is_finite() {
        return [128, 128, 128];
    }
    crate::canvas::ramp(f64::from((value - low) / (high - low)))
}

/// The ramp's ends for a map: the 5th and 95th percentiles of its uncertainty, so a few
/// outliers do not wash every other Gaussian into one colour.
pub fn uncertainty_range(uncertainty: &[f32]) -> (f32, f32) {
    let mut finite: Vec<f32> = uncertainty
        .iter()
        .copied()
        .filter(|u| u.is_finite())
        .collect();
    if finite.is_empty() {
        return (0.0, 0.0);
    }
    finite.sort_by(f32::total_cmp);
    let at = |q: f64| finite[((finite.len() - 1) as f64 * q).round() as usize];
    (at(0.05), at(0.95))
}

/// Depth in metres as the recording's 16-bit units (0 stays "no return").
pub fn depth_units(depth: &[f32]) -> Vec<u16> {
    depth
        .iter()
        .map(|&d| {
            if d.is_finite() && d > 0.0 {
                (d * DEPTH_PER_METRE)
                    .round()
                    .clamp(0.0, f32::from(u16::MAX)) as u16
            } else {
                0
            }
        })
        .collect()
}

/// An open recording; every call is a no-op for an episode without one.
pub struct RerunLog {
    #[cfg(feature = "rerun")]
    stream: rerun::RecordingStream,
    map_every: usize,
    map_steps: usize,
    /// The masks' labels, once [`RerunLog::labels`] gave them.
    labels: Option<std::sync::Arc<Labels>>,
}

/// Heights the flat things are drawn at, metres: the path just above the floor, plans above it.
#[cfg(feature = "rerun")]
const PATH_HEIGHT: f32 = 0.02;
#[cfg(feature = "rerun")]
const PLAN_HEIGHT: f32 = 0.05;

/// A planar path as 3D points at `height`.
#[cfg(feature = "rerun")]
fn lifted(states: impl IntoIterator<Item = Pose2>, height: f32) -> Vec<[f32; 3]> {
    states
        .into_iter()
        .map(|p| [p.x as f32, p.y as f32, height])
        .collect()
}

impl RerunLog {
    /// Opens the recording `target` asks for (checked by [`RerunTarget::check`] first); `None`
    /// when it asks for none. `name` is the recording's name in the viewer.
    pub fn open(target: &RerunTarget, name: &str) -> Result<Option<RerunLog>> {
        if !target.wanted() {
            return Ok(None);
        }
        Self::start(target, name).map(Some)
    }

    #[cfg(feature = "rerun")]
    fn start(target: &RerunTarget, name: &str) -> Result<RerunLog> {
        use rerun::sink::{FileSink, GrpcSink, LogSink};
        let failed = |source: Box<dyn std::error::Error + Send + Sync>| SimError::Rerun {
            what: "cannot start the recording",
            source,
        };
        let mut sinks: Vec<Box<dyn LogSink>> = Vec::new();
        if let Some(file) = &target.file {
            let sink = FileSink::new(file.clone()).map_err(|e| failed(Box::new(e)))?;
            sinks.push(Box::new(sink));
        }
        if let Some(address) = &target.connect {
            let uri = viewer_url(address)
                .parse::<rerun::external::re_uri::ProxyUri>()
                .map_err(|e| failed(Box::new(e)))?;
            sinks.push(Box::new(GrpcSink::new(uri)));
        }
        let stream = rerun::RecordingStreamBuilder::new("splatloop")
            .recording_name(name)
            .set_sinks(sinks)
            .map_err(|e| failed(Box::new(e)))?;
        let log = RerunLog {
            stream,
            map_every: target.map_every,
            map_steps: 0,
            labels: None,
        };
        log.emit_static("world", &rerun::ViewCoordinates::RIGHT_HAND_Z_UP())?;
        Ok(log)
    }

    #[cfg(not(feature = "rerun"))]
    fn start(_target: &RerunTarget, _name: &str) -> Result<RerunLog> {
        Err(not_built())
    }

    #[cfg(feature = "rerun")]
    fn emit<T: rerun::AsComponents + ?Sized>(&self, entity: &str, what: &T) -> Result<()> {
        self.stream.log(entity, what).map_err(|e| SimError::Rerun {
            what: "cannot log to the recording",
            source: Box::new(e),
        })
    }

    #[cfg(feature = "rerun")]
    fn emit_static<T: rerun::AsComponents + ?Sized>(&self, entity: &str, what: &T) -> Result<()> {
        self.stream
            .log_static(entity, what)
            .map_err(|e| SimError::Rerun {
                what: "cannot log to the recording",
                source: Box::new(e),
            })
    }

    /// Sets the time the next entries are logged at, simulated seconds.
    pub fn at(&self, time: f64) {
        #[cfg(feature = "rerun")]
        self.stream.set_duration_secs("sim_time", time.max(0.0));
        #[cfg(not(feature = "rerun"))]
        let _ = time;
    }

    /// The names of the masks' ids: instance and class names as the segmentation images'
    /// annotations (logged once, static).
    pub fn labels(&mut self, labels: std::sync::Arc<Labels>) -> Result<()> {
        #[cfg(feature = "rerun")]
        {
            let instances = rerun::AnnotationContext::new(
                labels
                    .instances
                    .iter()
                    .map(|i| (i.id, i.name.as_str()))
                    .collect::<Vec<_>>(),
            );
            self.emit_static("world/camera/instance", &instances)?;
            let classes = rerun::AnnotationContext::new(
                labels
                    .classes
                    .iter()
                    .map(|c| (c.id, c.name.as_str()))
                    .collect::<Vec<_>>(),
            );
            self.emit_static("world/camera/semantic", &classes)?;
        }
        self.labels = Some(labels);
        Ok(())
    }

    /// One camera frame: the camera's pose and intrinsics, its RGB (row-major, top row first),
    /// its planar depth in metres and its instance mask (empty without masks); and the robot's
    /// path so far.
    pub fn frame(
        &self,
        camera: &PinholeCamera,
        rgb: &[u8],
        depth: &[f32],
        instance: &[u16],
        path: &[Pose2],
    ) -> Result<()> {
        #[cfg(feature = "rerun")]
        {
            let k = &camera.intrinsics;
            let size = [k.width, k.height];
            let pose = &camera.world_from_camera;
            let t = pose.translation.vector;
            let r = pose.rotation.to_rotation_matrix();
            let m = r.matrix();
            // Column-major, as rerun's Mat3x3 takes its flat form.
            let columns = [
                m[(0, 0)] as f32,
                m[(1, 0)] as f32,
                m[(2, 0)] as f32,
                m[(0, 1)] as f32,
                m[(1, 1)] as f32,
                m[(2, 1)] as f32,
                m[(0, 2)] as f32,
                m[(1, 2)] as f32,
                m[(2, 2)] as f32,
            ];
            // The pose and the intrinsics in one row, so each frame is one entry.
            let transform = rerun::Transform3D::from_translation_mat3x3(
                [t.x as f32, t.y as f32, t.z as f32],
                rerun::datatypes::Mat3x3(columns),
            );
            let pinhole = rerun::Pinhole::from_focal_length_and_resolution(
                [k.fx as f32, k.fy as f32],
                [k.width as f32, k.height as f32],
            )
            .with_principal_point([k.cx as f32, k.cy as f32]);
            self.emit(
                "world/camera",
                &[&transform as &dyn rerun::AsComponents, &pinhole],
            )?;
            self.emit(
                "world/camera/rgb",
                &rerun::Image::from_rgb24(rgb.to_vec(), size),
            )?;
            let units = depth_units(depth);
            self.emit(
                "world/camera/depth",
                &rerun::DepthImage::from_gray16(le_bytes(&units), size).with_meter(DEPTH_PER_METRE),
            )?;
            if let Some(labels) = self.labels.as_ref().filter(|_| !instance.is_empty()) {
                let format = rerun::datatypes::ImageFormat::segmentation(
                    size,
                    rerun::datatypes::ChannelDatatype::U16,
                );
                self.emit(
                    "world/camera/instance",
                    &rerun::SegmentationImage::new(le_bytes(instance), format),
                )?;
                self.emit(
                    "world/camera/semantic",
                    &rerun::SegmentationImage::new(le_bytes(&labels.semantic(instance)), format),
                )?;
            }
            self.emit(
                "world/robot/path",
                &rerun::LineStrips3D::new([lifted(path.iter().copied(), PATH_HEIGHT)])
                    .with_colors([rerun::Color::from_rgb(40, 40, 40)]),
            )?;
        }
        #[cfg(not(feature = "rerun"))]
        let _ = (camera, rgb, depth, instance, path);
        Ok(())
    }

    /// One planning step: the candidates compared and the trajectory chosen.
    pub fn plan(&self, candidates: &[Vec<Pose2>], chosen: &[Pose2]) -> Result<()> {
        #[cfg(feature = "rerun")]
        {
            let strips: Vec<Vec<[f32; 3]>> = candidates
                .iter()
                .map(|c| lifted(c.iter().copied(), PLAN_HEIGHT))
                .collect();
            self.emit(
                "world/plan/candidates",
                &rerun::LineStrips3D::new(strips)
                    .with_colors([rerun::Color::from_rgb(150, 150, 150)]),
            )?;
            self.emit(
                "world/plan/chosen",
                &rerun::LineStrips3D::new([lifted(chosen.iter().copied(), PLAN_HEIGHT)])
                    .with_colors([rerun::Color::from_rgb(20, 180, 60)])
                    .with_radii([rerun::Radius::new_ui_points(3.0)]),
            )?;
        }
        #[cfg(not(feature = "rerun"))]
        let _ = (candidates, chosen);
        Ok(())
    }

    /// One mapping step: the map as points, every `map_every` steps.
    pub fn map(&mut self, map: &GaussianMap) -> Result<()> {
        self.map_steps += 1;
        if !(self.map_steps - 1).is_multiple_of(self.map_every) {
            return Ok(());
        }
        #[cfg(feature = "rerun")]
        {
            let g = &map.gaussians;
            let positions = g.means.clone();
            let radii: Vec<f32> = g.log_radii.iter().map(|r| r.exp()).collect();
            let colours: Vec<rerun::Color> = g
                .colours
                .iter()
                .map(|c| {
                    let byte = |v: f32| (v.clamp(0.0, 1.0) * 255.0).round() as u8;
                    rerun::Color::from_rgb(byte(c[0]), byte(c[1]), byte(c[2]))
                })
                .collect();
            self.emit(
                "world/map/colour",
                &rerun::Points3D::new(positions.clone())
                    .with_colors(colours)
                    .with_radii(radii.clone()),
            )?;
            let (low, high) = uncertainty_range(&map.uncertainty);
            let ramp: Vec<rerun::Color> = map
                .uncertainty
                .iter()
                .map(|u| {
                    let [r, g, b] = uncertainty_colour(*u, low, high);
                    rerun::Color::from_rgb(r, g, b)
                })
                .collect();
            self.emit(
                "world/map/uncertainty",
                &rerun::Points3D::new(positions)
                    .with_colors(ramp)
                    .with_radii(radii),
            )?;
        }
        #[cfg(not(feature = "rerun"))]
        let _ = map;
        Ok(())
    }

    /// A scalar time series (coverage, stage times), by its entity path.
    pub fn scalar(&self, entity: &str, value: f64) -> Result<()> {
        #[cfg(feature = "rerun")]
        self.emit(entity, &rerun::Scalars::new([value]))?;
        #[cfg(not(feature = "rerun"))]
        let _ = (entity, value);
        Ok(())
    }

    /// Writes out everything logged (the file is complete when this returns).
    pub fn finish(self) -> Result<()> {
        #[cfg(feature = "rerun")]
        self.stream.flush_blocking().map_err(|e| SimError::Rerun {
            what: "cannot finish the recording",
            source: Box::new(e),
        })?;
        Ok(())
    }
}

/// 16-bit samples as the little-endian bytes rerun's image buffers hold.
#[cfg(feature = "rerun")]
fn le_bytes(units: &[u16]) -> Vec<u8> {
    units.iter().flat_map(|u| u.to_le_bytes()).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn depth_units_are_the_dataset_scale_and_zero_where_there_is_no_return() {
        let depth = [0.0, 1.0, 2.34567, f32::NAN, -1.0, 20.0];
        let units = depth_units(&depth);
        assert_eq!(units[0], 0);
        assert_eq!(units[1], 5000);
        assert!((f32::from(units[2]) / DEPTH_PER_METRE - 2.34567).abs() <= 0.5 / DEPTH_PER_METRE);
        assert_eq!(units[3], 0);
        assert_eq!(units[4], 0);
        // Beyond the 16-bit range (13.1 m) it saturates instead of wrapping.
        assert_eq!(units[5], u16::MAX);
    }

    #[test]
    fn the_uncertainty_ramp_runs_blue_to_red_between_the_percentiles() {
        let values: Vec<f32> = (0..=100).map(|i| i as f32).collect();
        let (low, high) = uncertainty_range(&values);
        assert_eq!((low, high), (5.0, 95.0));
        // trajectory.png's ramp: blue below `low`, red above `high`, and half way between its
        // green and yellow stops in the middle.
        assert_eq!(uncertainty_colour(0.0, low, high), [40, 70, 200]);
        assert_eq!(uncertainty_colour(50.0, low, high), [140, 190, 65]);
        assert_eq!(uncertainty_colour(100.0, low, high), [210, 40, 40]);
        assert_eq!(uncertainty_colour(1.0, 2.0, 2.0), [128, 128, 128]);
        assert_eq!(uncertainty_range(&[f32::NAN]), (0.0, 0.0));
    }

    #[test]
    fn a_viewer_address_becomes_its_grpc_url() {
        assert_eq!(
            viewer_url("127.0.0.1:9876"),
            "rerun+http://127.0.0.1:9876/proxy"
        );
        assert_eq!(
            viewer_url("rerun+http://host:1/proxy"),
            "rerun+http://host:1/proxy"
        );
    }
}
