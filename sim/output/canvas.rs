//! A small RGB raster for the pictures splatloop writes (trajectory.png, the sweep's charts):
//! discs, lines, 8x8 text and swatches, with an optional mapping from floor metres to pixels.

use crate::error::{Result, SimError};
use std::path::Path;

/// Blue -> green -> yellow -> red for t in [0, 1]: the one ramp every picture and recording
/// shows uncertainty on, so trajectory.png and rerun's map read the same.
pub(crate) fn ramp(t: f64) -> [u8; 3] {
    let stops = [
        [40.0, 70.0, 200.0],
        [40.0, 170.0, 90.0],
        [240.0, 210.0, 40.0],
        [210.0, 40.0, 40.0],
    ];
    let x = t.clamp(0.0, 1.0) * 3.0;
    let k = (x.floor() as usize).min(2);
    let f = x - k as f64;
    std::array::from_fn(|c| (stops[k][c] + f * (stops[k + 1][c] - stops[k][c])) as u8)
}

/// An RGB canvas, white when new; over a rectangle of the floor (`lo`, `scale` pixels per
/// metre) y (north) points up the picture. A chart uses pixel coordinates (`blank`).
pub(crate) struct Canvas {
    pub(crate) lo: [f64; 2],
    pub(crate) scale: f64,
    pub(crate) width: usize,
    pub(crate) height: usize,
    pub(crate) rgb: Vec<u8>,
}

impl Canvas {
    /// A white canvas of `width` x `height` pixels, pixel coordinates.
    pub(crate) fn blank(width: usize, height: usize) -> Self {
        Canvas {
            lo: [0.0; 2],
            scale: 1.0,
            width,
            height,
            rgb: vec![255; 3 * width * height],
        }
    }

    /// Writes the canvas as an 8-bit RGB PNG.
    pub(crate) fn write_png(&self, path: &Path) -> Result<()> {
        write_rgb(path, self.width, self.height, &self.rgb)
    }

    pub(crate) fn pixel_of(&self, x: f64, y: f64) -> (f64, f64) {
        (
            (x - self.lo[0]) * self.scale,
            self.height as f64 - (y - self.lo[1]) * self.scale,
        )
    }

    pub(crate) fn world_of(&self, px: usize, py: usize) -> (f64, f64) {
        (
            self.lo[0] + (px as f64 + 0.5) / self.scale,
            self.lo[1] + (self.height as f64 - py as f64 - 0.5) / self.scale,
        )
    }

    pub(crate) fn put(&mut self, px: f64, py: f64, colour: [u8; 3]) {
        if px >= 0.0 && py >= 0.0 && (px as usize) < self.width && (py as usize) < self.height {
            let i = 3 * (py as usize * self.width + px as usize);
            self.rgb[i..i + 3].copy_from_slice(&colour);
        }
    }

    pub(crate) fn disc(&mut self, px: f64, py: f64, radius: f64, colour: [u8; 3]) {
        let r = radius.ceil() as i64;
        for dy in -r..=r {
            for dx in -r..=r {
                if ((dx * dx + dy * dy) as f64) <= radius * radius {
                    self.put(px + dx as f64, py + dy as f64, colour);
                }
            }
        }
    }

    pub(crate) fn line(&mut self, a: (f64, f64), b: (f64, f64), radius: f64, colour: [u8; 3]) {
        let steps = ((b.0 - a.0).hypot(b.1 - a.1) * 2.0).ceil().max(1.0) as usize;
        for k in 0..=steps {
            let t = k as f64 / steps as f64;
            self.disc(a.0 + t * (b.0 - a.0), a.1 + t * (b.1 - a.1), radius, colour);
        }
    }
}

impl Canvas {
    /// Writes `text` with its top-left corner at (x, y) in 8x8 glyphs.
    pub(crate) fn text(&mut self, x: usize, y: usize, text: &str, colour: [u8; 3]) {
        use font8x8::UnicodeFonts;
        for (k, c) in text.chars().enumerate() {
            let glyph = font8x8::BASIC_FONTS.get(c).unwrap_or([0; 8]);
            for (row, bits) in glyph.iter().enumerate() {
                for col in 0..8 {
                    if bits >> col & 1 == 1 {
                        self.put((x + 8 * k + col) as f64, (y + row) as f64, colour);
                    }
                }
            }
        }
    }

    /// A 10 x 10 square of `colour` with a thin dark border.
    pub(crate) fn swatch(&mut self, x: usize, y: usize, colour: [u8; 3]) {
        for dy in 0..10 {
            for dx in 0..10 {
                let edge = dx == 0 || dy == 0 || dx == 9 || dy == 9;
                self.put(
                    (x + dx) as f64,
                    (y + dy) as f64,
                    if edge { [60, 60, 60] } else { colour },
                );
            }
        }
    }
}

/// Writes `rgb` (rows of `width` RGB pixels) as an 8-bit PNG; a picture too large for PNG's
/// 32-bit sides is an error naming the file.
pub(crate) fn write_rgb(path: &Path, width: usize, height: usize, rgb: &[u8]) -> Result<()> {
    let too_big = || {
        SimError::io(
            "cannot write",
            path,
            std::io::Error::other("the picture is too large"),
        )
    };
    let w = u32::try_from(width).map_err(|_| too_big())?;
    let h = u32::try_from(height).map_err(|_| too_big())?;
    crate::dataset::write_rgb_png(path, w, h, rgb)
}
