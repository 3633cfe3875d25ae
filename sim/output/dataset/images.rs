//! PNG files of the dataset: 8-bit RGB, 16-bit depth (TUM: 5000 units per metre) and 16-bit
//! label masks (instance and semantic ids).

use super::DEPTH_SCALE;
use crate::error::{Result, SimError};
use std::fs::File;
use std::io::{BufReader, BufWriter};
use std::path::Path;

fn encode(
    path: &Path,
    width: u32,
    height: u32,
    color: png::ColorType,
    depth: png::BitDepth,
    bytes: &[u8],
) -> Result<()> {
    let io = |e| SimError::io("cannot write", path, e);
    let file = File::create(path).map_err(io)?;
    let mut encoder = png::Encoder::new(BufWriter::new(file), width, height);
    encoder.set_color(color);
    encoder.set_depth(depth);
    encoder.set_compression(png::Compression::Fast);
    let to_io =
        |e: png::EncodingError| SimError::io("cannot write", path, std::io::Error::other(e));
    let mut writer = encoder.write_header().map_err(to_io)?;
    writer.write_image_data(bytes).map_err(to_io)?;
    writer.finish().map_err(to_io)
}

/// Writes interleaved 8-bit RGB, rows top to bottom.
pub fn write_rgb_png(path: &Path, width: u32, height: u32, rgb: &[u8]) -> Result<()> {
    encode(
        path,
        width,
        height,
        png::ColorType::Rgb,
        png::BitDepth::Eight,
        rgb,
    )
}

/// Writes metric depth as 16-bit PNG (0 = no return); values beyond 13.1 m saturate.
pub fn write_depth_png(path: &Path, width: u32, height: u32, depth: &[f32]) -> Result<()> {
    let units: Vec<u16> = depth
        .iter()
        .map(|&d| (f64::from(d) * DEPTH_SCALE).round().clamp(0.0, 65535.0) as u16)
        .collect();
    write_mask_png(path, width, height, &units)
}

/// Writes a 16-bit mask (an id per pixel, 0 = nothing), rows top to bottom.
pub fn write_mask_png(path: &Path, width: u32, height: u32, ids: &[u16]) -> Result<()> {
    let bytes: Vec<u8> = ids.iter().flat_map(|id| id.to_be_bytes()).collect();
    encode(
        path,
        width,
        height,
        png::ColorType::Grayscale,
        png::BitDepth::Sixteen,
        &bytes,
    )
}

/// Reads a 16-bit mask PNG: (width, height, ids).
pub fn read_mask_png(path: &Path) -> Result<(u32, u32, Vec<u16>)> {
    read_grey16(path, "mask")
}

/// Reads a 16-bit grey PNG (`what` names it in the error): (width, height, samples).
fn read_grey16(path: &Path, what: &str) -> Result<(u32, u32, Vec<u16>)> {
    let (info, bytes) = decode(path)?;
    if info.color_type != png::ColorType::Grayscale || info.bit_depth != png::BitDepth::Sixteen {
        return Err(SimError::BadDataset {
            path: path.to_owned(),
            detail: format!(
                "expected a 16-bit grey {what}, found {:?} {:?}",
                info.color_type, info.bit_depth
            ),
        });
    }
    let samples = bytes
        .chunks_exact(2)
        .map(|b| u16::from_be_bytes([b[0], b[1]]))
        .collect();
    Ok((info.width, info.height, samples))
}

fn decode(path: &Path) -> Result<(png::OutputInfo, Vec<u8>)> {
    let file = File::open(path).map_err(|e| SimError::io("cannot read", path, e))?;
    let bad = |detail: String| SimError::BadDataset {
        path: path.to_owned(),
        detail,
    };
    let mut reader = png::Decoder::new(BufReader::new(file))
        .read_info()
        .map_err(|e| bad(e.to_string()))?;
    let mut bytes = vec![0; reader.output_buffer_size()];
    let info = reader
        .next_frame(&mut bytes)
        .map_err(|e| bad(e.to_string()))?;
    bytes.truncate(info.buffer_size());
    Ok((info, bytes))
}

/// Reads an 8-bit RGB PNG: (width, height, bytes).
pub fn read_rgb_png(path: &Path) -> Result<(u32, u32, Vec<u8>)> {
    let (info, bytes) = decode(path)?;
    if info.color_type != png::ColorType::Rgb || info.bit_depth != png::BitDepth::Eight {
        return Err(SimError::BadDataset {
            path: path.to_owned(),
            detail: format!(
                "expected 8-bit RGB, found {:?} {:?}",
                info.color_type, info.bit_depth
            ),
        });
    }
    Ok((info.width, info.height, bytes))
}

/// Reads a 16-bit depth PNG into metres: (width, height, depth).
pub fn read_depth_png(path: &Path) -> Result<(u32, u32, Vec<f32>)> {
    let (width, height, units) = read_grey16(path, "depth")?;
    let depth = units
        .into_iter()
        .map(|u| (f64::from(u) / DEPTH_SCALE) as f32)
        .collect();
    Ok((width, height, depth))
}
