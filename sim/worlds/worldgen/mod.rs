//! `splatloop world generate`: seeded worlds of three kinds (apartment, office, warehouse)
//! written as MJCF that includes the robot and reuses `worlds/assets/`. Each candidate is laid
//! out valid by construction, written beside the target, compiled by MuJoCo and put through
//! `world check` and its door checks; only a candidate that passes takes the target's name,
//! otherwise the next sub-seed is tried. The same seed and options give the same bytes.

pub mod kinds;
pub mod layout;
pub mod mjcf;

use crate::camera::SensorConfig;
use crate::error::{Result, SimError};
use crate::world::World;
use crate::world_check::{check_world, WorldReport};
use layout::Layout;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::Serialize;
use std::path::{Component, Path, PathBuf};

/// Centre-line area per m2 of floor wanted: the outer walls' half thickness is added back.
const AREA_INFLATION: f64 = 1.03;

/// How close an asked floor area is made: within this share of it (the kind's range bounds
/// only drawn areas).
const AREA_TOLERANCE: f64 = 0.02;

/// Rescalings of one candidate toward an asked area.
const AREA_STEPS: usize = 4;

/// Candidates tried before giving up on a seed.
const MAX_CANDIDATES: u32 = 64;

/// The kinds of world the generator makes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum WorldKind {
    /// 3-6 rooms joined by doors, 50-120 m2.
    Apartment,
    /// A corridor with 4-8 rooms off it, 80-200 m2.
    Office,
    /// An open hall with shelving rows and a few walled rooms, 120-300 m2.
    Warehouse,
}

impl WorldKind {
    /// Every kind, in the suite's order.
    pub const ALL: [WorldKind; 3] = [
        WorldKind::Apartment,
        WorldKind::Office,
        WorldKind::Warehouse,
    ];

    /// The name on the command line.
    pub fn name(self) -> &'static str {
        match self {
            WorldKind::Apartment => "apartment",
            WorldKind::Office => "office",
            WorldKind::Warehouse => "warehouse",
        }
    }

    /// The floor areas this kind is made in, m2.
    pub fn area_range(self) -> (f64, f64) {
        match self {
            WorldKind::Apartment => (50.0, 120.0),
            WorldKind::Office => (80.0, 200.0),
            WorldKind::Warehouse => (120.0, 300.0),
        }
    }

    fn layout(self, area: f64, rng: &mut ChaCha8Rng) -> Option<Layout> {
        match self {
            WorldKind::Apartment => kinds::apartment(area, rng),
            WorldKind::Office => kinds::office(area, rng),
            WorldKind::Warehouse => kinds::warehouse(area, rng),
        }
    }
}

impl std::str::FromStr for WorldKind {
    type Err = String;

    fn from_str(s: &str) -> std::result::Result<Self, String> {
        WorldKind::ALL
            .into_iter()
            .find(|k| k.name() == s)
            .ok_or_else(|| format!("unknown world kind {s:?}; use apartment, office or warehouse"))
    }
}

/// What to generate.
#[derive(Debug, Clone)]
pub struct GenerateConfig {
    /// The kind.
    pub kind: WorldKind,
    /// The seed.
    pub seed: u64,
    /// Floor area wanted, m2 (inside the kind's range); drawn from the range when absent.
    pub area: Option<f64>,
    /// The MJCF file to write.
    pub out: PathBuf,
    /// Replace an existing file.
    pub overwrite: bool,
}

/// A world that was written, with what it holds.
#[derive(Debug, Clone, Serialize)]
pub struct GeneratedWorld {
    /// The file.
    pub file: PathBuf,
    /// Its kind.
    pub kind: WorldKind,
    /// The seed asked for.
    pub seed: u64,
    /// The candidate that passed (0: the first).
    pub sub_seed: u32,
    /// Floor area inside the outer walls, m2.
    pub area: f64,
    /// Rooms (corridors and halls not counted).
    pub rooms: usize,
    /// Doors.
    pub doors: usize,
    /// The doors' clear widths, metres.
    pub door_widths: Vec<f64>,
    /// Wall height, metres.
    pub wall_height: f64,
    /// The check of the written world.
    pub report: WorldReport,
}

/// Generates a world; `on_reject` hears of every candidate that failed its checks.
pub fn generate(
    config: &GenerateConfig,
    on_reject: &mut dyn FnMut(u32, &str),
) -> Result<GeneratedWorld> {
    let (lo, hi) = config.kind.area_range();
    if let Some(a) = config.area {
        if !(a.is_finite() && (lo..=hi).contains(&a)) {
            return Err(SimError::InvalidArgument {
                what: "area",
                detail: format!(
                    "{a} m2; {} {} is generated between {lo} and {hi} m2",
                    if config.kind.name().starts_with(['a', 'e', 'i', 'o', 'u']) {
                        "an"
                    } else {
                        "a"
                    },
                    config.kind.name()
                ),
            });
        }
    }
    crate::dataset::refuse_overwrite(&config.out, config.overwrite, &[])?;
    let folder = match config.out.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    std::fs::create_dir_all(&folder).map_err(|e| SimError::io("cannot create", &folder, e))?;
    let paths = asset_paths(&folder)?;
    let file_name = config
        .out
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let candidate = folder.join(format!(".{file_name}.candidate.xml"));
    for sub_seed in 0..MAX_CANDIDATES {
        let mut rng = ChaCha8Rng::seed_from_u64(config.seed);
        rng.set_stream(u64::from(sub_seed));
        let area = config
            .area
            .unwrap_or_else(|| rand::Rng::gen_range(&mut rng, lo..=hi));
        let drawn = rng.clone();
        // The kinds lay out centre lines; the floor inside the walls is a little smaller.
        let Some(mut layout) = config.kind.layout(area * AREA_INFLATION, &mut rng) else {
            on_reject(sub_seed, "the rooms and doors did not fit");
            continue;
        };
        if let Some(asked) = config.area {
            // The inflation is a mean over layouts: steer this candidate onto the asked floor
            // (the same draws, a rescaled target), so an area at the range's edge is made.
            let mut target = area * AREA_INFLATION;
            for _ in 0..AREA_STEPS {
                let floor = layout.floor_area();
                if (floor - asked).abs() <= 0.25 * AREA_TOLERANCE * asked {
                    break;
                }
                target *= asked / floor;
                match config.kind.layout(target, &mut drawn.clone()) {
                    Some(closer) => layout = closer,
                    None => break,
                }
            }
        }
        let floor = layout.floor_area();
        let fits = match config.area {
            Some(asked) => (floor - asked).abs() <= AREA_TOLERANCE * asked,
            None => (lo..=hi).contains(&floor),
        };
        if !fits {
            let wanted = match config.area {
                Some(asked) => format!("{:.0}% of the asked {asked} m2", 100.0 * AREA_TOLERANCE),
                None => format!("{lo}-{hi} m2"),
            };
            on_reject(
                sub_seed,
                &format!("its floor of {floor:.1} m2 is not within {wanted}"),
            );
            continue;
        }
        let header = mjcf::Header {
            kind: config.kind,
            seed: config.seed,
            sub_seed,
        };
        let text = mjcf::write(&layout, &header, &paths);
        std::fs::write(&candidate, &text)
            .map_err(|e| SimError::io("cannot write", &candidate, e))?;
        let checked = check_candidate(&candidate, &layout);
        let report = match checked {
            Ok(r) => r,
            Err(e) => {
                let _ = std::fs::remove_file(&candidate);
                return Err(e);
            }
        };
        if !report.ok() {
            on_reject(sub_seed, &report.problems.join("; "));
            continue;
        }
        std::fs::rename(&candidate, &config.out)
            .map_err(|e| SimError::io("cannot write", &config.out, e))?;
        return Ok(GeneratedWorld {
            file: config.out.clone(),
            kind: config.kind,
            seed: config.seed,
            sub_seed,
            area: layout.floor_area(),
            rooms: layout.rooms.iter().filter(|r| r.furnished).count(),
            doors: layout.doors.len(),
            door_widths: layout.doors.iter().map(|d| d.width).collect(),
            wall_height: layout.wall_height,
            report,
        });
    }
    let _ = std::fs::remove_file(&candidate);
    Err(SimError::InvalidArgument {
        what: "seed",
        detail: format!(
            "no valid {} in {MAX_CANDIDATES} candidates of seed {}; try another seed or area",
            config.kind.name(),
            config.seed
        ),
    })
}

/// `world check` on the compiled candidate, plus what only the layout knows: every door is
/// passable (its middle is reachable).
fn check_candidate(path: &Path, layout: &Layout) -> Result<WorldReport> {
    let world = World::load(path, &SensorConfig::default())?;
    let (mut report, plan) = check_world(&world)?;
    let reachable = plan.reachable_from(layout.spawn.x, layout.spawn.y);
    for door in &layout.doors {
        let wall = layout.walls[door.wall];
        let (x, y) = if wall.along == 0 {
            (door.centre, wall.at)
        } else {
            (wall.at, door.centre)
        };
        if !plan.cell_of(x, y).is_some_and(|c| reachable[c]) {
            report.problems.push(format!(
                "the {:.2} m door at ({x:.2}, {y:.2}) cannot be passed",
                door.width
            ));
        }
    }
    Ok(report)
}

/// How a world written into `folder` finds `models/unicycle.xml` and `worlds/assets/`:
/// relative paths to the splatloop checkout that holds the folder, or else the current
/// directory's, or else the one this binary was built from.
pub fn asset_paths(folder: &Path) -> Result<Paths> {
    let absolute =
        |p: &Path| std::fs::canonicalize(p).map_err(|e| SimError::io("cannot resolve", p, e));
    let folder = absolute(folder)?;
    let has_robot = |root: &Path| {
        root.join("models/unicycle.xml").is_file() && root.join("worlds/assets").is_dir()
    };
    let mut roots: Vec<PathBuf> = folder.ancestors().map(Path::to_path_buf).collect();
    if let Ok(cwd) = std::env::current_dir() {
        roots.push(cwd);
    }
    roots.push(PathBuf::from(env!("CARGO_MANIFEST_DIR")));
    let root = roots.into_iter().find(|r| has_robot(r)).ok_or_else(|| SimError::MissingFile {
        what: "robot model (models/unicycle.xml beside worlds/assets/; run from the splatloop checkout)",
        path: PathBuf::from("models/unicycle.xml"),
    })?;
    let root = absolute(&root)?;
    Ok(Paths {
        robot: relative(&folder, &root.join("models/unicycle.xml")),
        assets: relative(&folder, &root.join("worlds/assets")),
    })
}

pub use mjcf::Paths;

/// `to` relative to the folder `from` (both absolute), with forward slashes.
pub fn relative(from: &Path, to: &Path) -> String {
    let a: Vec<Component> = from.components().collect();
    let b: Vec<Component> = to.components().collect();
    let common = a.iter().zip(&b).take_while(|(x, y)| x == y).count();
    let mut parts: Vec<String> = vec!["..".into(); a.len() - common];
    parts.extend(
        b[common..]
            .iter()
            .map(|c| c.as_os_str().to_string_lossy().into_owned()),
    );
    parts.join("/")
}
