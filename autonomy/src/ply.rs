//! The map as a standard 3DGS PLY (DESIGN.md "Export"): binary little-endian float32
//! x y z nx ny nz f_dc_0..2 opacity scale_0..2 rot_0..3, logit opacity, log scales, rotation w
//! first, f_dc = (c - 0.5) / C0, plus one extra float `uncertainty`. Readers of 3DGS files
//! (viewers, nerfstudio) ignore the extra property; ours reads files from other 3DGS tools too
//! (extra properties such as f_rest_* are skipped, anisotropic scales averaged in log space).

use crate::gaussians::Gaussians;
use crate::map::GaussianMap;
use std::io::{BufRead, BufReader, BufWriter, Read, Write};
use std::path::Path;
use thiserror::Error;

/// The zeroth-order spherical-harmonic constant that maps f_dc to colour.
pub const SH_C0: f32 = 0.282_094_8;

const PROPERTIES: [&str; 18] = [
    "x",
    "y",
    "z",
    "nx",
    "ny",
    "nz",
    "f_dc_0",
    "f_dc_1",
    "f_dc_2",
    "opacity",
    "scale_0",
    "scale_1",
    "scale_2",
    "rot_0",
    "rot_1",
    "rot_2",
    "rot_3",
    "uncertainty",
];

/// Why a PLY could not be written or read.
#[derive(Debug, Error)]
pub enum PlyError {
    /// The file system refused.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// The cause.
        source: std::io::Error,
    },
    /// Not a PLY this reader understands.
    #[error("{path}: not a 3DGS PLY: {reason}")]
    Foreign {
        /// The file.
        path: String,
        /// What is wrong.
        reason: String,
    },
    /// Shorter than its header says.
    #[error(
        "{path}: truncated: the header declares {expected} Gaussians but the data holds {found}"
    )]
    Truncated {
        /// The file.
        path: String,
        /// Declared.
        expected: usize,
        /// Complete records found.
        found: usize,
    },
    /// The parameters hold NaN or infinities.
    #[error("{path}: Gaussian {index} has non-finite parameters")]
    NotFinite {
        /// The file.
        path: String,
        /// Which Gaussian.
        index: usize,
    },
}

fn io_error(path: &Path) -> impl FnOnce(std::io::Error) -> PlyError + '_ {
    move |source| PlyError::Io {
        path: path.display().to_string(),
        source,
    }
}

/// Writes `map` to `path`.
pub fn write(map: &GaussianMap, path: &Path) -> Result<(), PlyError> {
    write_with_sh_degree(map, path, 0)
}

/// Higher spherical-harmonic coefficients per Gaussian at degree 3 (15 per colour channel).
const SH_REST_DEGREE_3: usize = 45;

/// Writes the map with its colours as spherical harmonics of `degree` 0 or 3. Degree 3 adds
/// f_rest_0..44, all zero (the same colours), which the reference 3DGS loader requires at
/// its default degree; degree 0 is the compact file every other reader takes.
pub fn write_with_sh_degree(map: &GaussianMap, path: &Path, degree: u8) -> Result<(), PlyError> {
    let rest = match degree {
        0 => 0,
        3 => SH_REST_DEGREE_3,
        other => {
            return Err(PlyError::Foreign {
                path: path.display().to_string(),
                reason: format!("spherical-harmonic degree {other} is not written; use 0 or 3"),
            })
        }
    };
    let file = std::fs::File::create(path).map_err(io_error(path))?;
    let mut out = BufWriter::new(file);
    let g = &map.gaussians;
    let mut header = format!(
        "ply\nformat binary_little_endian 1.0\ncomment splatloop isotropic Gaussian map\nelement vertex {}\n",
        g.len()
    );
    for p in PROPERTIES {
        header.push_str(&format!("property float {p}\n"));
        if p == "f_dc_2" {
            for k in 0..rest {
                header.push_str(&format!("property float f_rest_{k}\n"));
            }
        }
    }
    header.push_str("end_header\n");
    out.write_all(header.as_bytes()).map_err(io_error(path))?;
    let mut record = Vec::with_capacity(PROPERTIES.len() * 4);
    for i in 0..g.len() {
        let m = g.means[i];
        let c = g.colours[i];
        let s = g.log_radii[i];
        let values = [
            m[0],
            m[1],
            m[2],
            0.0,
            0.0,
            0.0,
            (c[0] - 0.5) / SH_C0,
            (c[1] - 0.5) / SH_C0,
            (c[2] - 0.5) / SH_C0,
            g.logit_opacities[i],
            s,
            s,
            s,
            1.0,
            0.0,
            0.0,
            0.0,
            map.uncertainty.get(i).copied().unwrap_or(0.0),
        ];
        record.clear();
        for (k, v) in values.iter().enumerate() {
            record.extend_from_slice(&v.to_le_bytes());
            // After f_dc_2 (the 9th value), the zero higher harmonics.
            if k == 8 {
                record.extend(std::iter::repeat_n(0u8, 4 * rest));
            }
        }
        out.write_all(&record).map_err(io_error(path))?;
    }
    out.flush().map_err(io_error(path))
}

/// Reads a map written by [`write`] or by another 3DGS tool.
pub fn read(path: &Path) -> Result<GaussianMap, PlyError> {
    let foreign = |reason: String| PlyError::Foreign {
        path: path.display().to_string(),
        reason,
    };
    let file = std::fs::File::open(path).map_err(io_error(path))?;
    let mut input = BufReader::new(file);
    let mut line = String::new();
    let mut next_line = |input: &mut BufReader<std::fs::File>| -> Result<String, PlyError> {
        line.clear();
        let n = input.read_line(&mut line).map_err(io_error(path))?;
        if n == 0 {
            return Err(foreign("the header ends before end_header".into()));
        }
        Ok(line.trim_end().to_owned())
    };
    if next_line(&mut input)? != "ply" {
        return Err(foreign("it does not start with \"ply\"".into()));
    }
    let mut count: Option<usize> = None;
    let mut properties: Vec<String> = Vec::new();
    let mut in_vertex = false;
    loop {
        let l = next_line(&mut input)?;
        let words: Vec<&str> = l.split_whitespace().collect();
        match words.as_slice() {
            ["end_header"] => break,
            ["format", "binary_little_endian", _] => {}
            ["format", other, _] => {
                return Err(foreign(format!(
                    "format {other} (only binary_little_endian is read)"
                )))
            }
            ["comment", ..] | ["obj_info", ..] => {}
            ["element", "vertex", n] => {
                count = Some(
                    n.parse()
                        .map_err(|_| foreign(format!("bad vertex count {n:?}")))?,
                );
                in_vertex = true;
            }
            ["element", other, ..] => {
                return Err(foreign(format!("unexpected element {other:?}")));
            }
            ["property", "float", name] if in_vertex => properties.push((*name).to_owned()),
            ["property", kind, name] if in_vertex => {
                return Err(foreign(format!(
                    "property {name} is {kind}; 3DGS files hold float32 only"
                )))
            }
            _ => return Err(foreign(format!("unexpected header line {l:?}"))),
        }
    }
    let count = count.ok_or_else(|| foreign("no vertex element".into()))?;
    let index = |name: &str| properties.iter().position(|p| p == name);
    let required = [
        "x", "y", "z", "f_dc_0", "f_dc_1", "f_dc_2", "opacity", "scale_0",
    ];
    let mut columns = Vec::new();
    for name in required {
        columns.push(index(name).ok_or_else(|| foreign(format!("no {name} property")))?);
    }
    let scales: Vec<usize> = ["scale_0", "scale_1", "scale_2"]
        .iter()
        .filter_map(|n| index(n))
        .collect();
    let uncertainty = index("uncertainty");
    let stride = properties.len() * 4;
    // The header's count is only a claim: memory is reserved for what the file can hold, so a
    // damaged count is a clear error instead of an allocation the machine cannot make.
    let data_bytes = std::fs::metadata(path).map_err(io_error(path))?.len() as usize;
    if stride > 0 && count > data_bytes / stride {
        return Err(PlyError::Truncated {
            path: path.display().to_string(),
            expected: count,
            found: data_bytes / stride,
        });
    }
    let mut map = GaussianMap::new(Gaussians::default(), Vec::with_capacity(count));
    let mut record = vec![0u8; stride];
    let mut anisotropic = 0usize;
    for i in 0..count {
        if let Err(e) = input.read_exact(&mut record) {
            return if e.kind() == std::io::ErrorKind::UnexpectedEof {
                Err(PlyError::Truncated {
                    path: path.display().to_string(),
                    expected: count,
                    found: i,
                })
            } else {
                Err(io_error(path)(e))
            };
        }
        let value = |column: usize| {
            let b = &record[4 * column..4 * column + 4];
            f32::from_le_bytes([b[0], b[1], b[2], b[3]])
        };
        let v: Vec<f32> = columns.iter().map(|c| value(*c)).collect();
        let log_radius = if scales.len() == 3 && scales.iter().any(|c| value(*c) != v[7]) {
            anisotropic += 1;
            scales.iter().map(|c| value(*c)).sum::<f32>() / 3.0
        } else {
            v[7]
        };
        let g = &mut map.gaussians;
        g.means.push([v[0], v[1], v[2]]);
        g.colours.push([v[3], v[4], v[5]].map(|f| 0.5 + SH_C0 * f));
        g.logit_opacities.push(v[6]);
        g.log_radii.push(log_radius);
        map.uncertainty.push(uncertainty.map_or(0.0, value));
        if !(v.iter().all(|x| x.is_finite()) && map.uncertainty[i].is_finite()) {
            return Err(PlyError::NotFinite {
                path: path.display().to_string(),
                index: i,
            });
        }
    }
    // This map holds isotropic Gaussians with one colour each: say what was changed.
    if anisotropic > 0 {
        tracing::warn!(
            "{}: {anisotropic} of {count} Gaussians were anisotropic: made isotropic by the geometric mean of their scales, rotations ignored",
            path.display()
        );
    }
    let harmonics = properties
        .iter()
        .filter(|p| p.starts_with("f_rest_"))
        .count();
    if harmonics > 0 {
        tracing::warn!(
            "{}: {harmonics} higher spherical-harmonic coefficients per Gaussian (f_rest_*) dropped: colours are the degree-0 term",
            path.display()
        );
    }
    map.adopt_new_gaussians();
    Ok(map)
}
