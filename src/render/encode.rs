//! PNG and animated GIF output, with atomic file writes.

use std::path::Path;

use tiny_skia::Pixmap;

use super::RenderError;

/// How much longer than the others the last GIF frame is shown, so the
/// final state can be seen before the animation loops.
const LAST_FRAME_HOLD: u16 = 4;

/// NeuQuant speed for GIF quantisation: 1 is best and slowest, 30 fastest;
/// 10 is the gif crate's recommended balance.
const GIF_SPEED: i32 = 10;

/// Encodes `p` as a PNG file in memory.
pub fn png_bytes(p: &Pixmap) -> Result<Vec<u8>, RenderError> {
    p.encode_png().map_err(|e| RenderError::Png(e.to_string()))
}

/// Writes `p` as a PNG to `path` atomically: readers never see a partial
/// file, and on error no temporary file is left behind.
pub fn write_png(path: &Path, p: &Pixmap) -> Result<(), RenderError> {
    write_atomic(path, &png_bytes(p)?)
}

/// Encodes `frames` as an endlessly looping animated GIF, each frame shown
/// for `delay_centiseconds` and the last one four times as long. Each frame
/// gets its own 256-colour palette. All frames must have the same size, at
/// most 65535 pixels each way.
pub fn gif_bytes(frames: &[Pixmap], delay_centiseconds: u16) -> Result<Vec<u8>, RenderError> {
    let first = frames.first().ok_or(RenderError::NoFrames)?;
    let (w, h) = (first.width(), first.height());
    let too_big = || RenderError::ImageSize {
        width: w,
        height: h,
    };
    let (w16, h16) = (
        u16::try_from(w).map_err(|_| too_big())?,
        u16::try_from(h).map_err(|_| too_big())?,
    );
    if let Some((index, f)) = frames
        .iter()
        .enumerate()
        .find(|(_, f)| (f.width(), f.height()) != (w, h))
    {
        return Err(RenderError::FrameSize {
            index,
            expected: (w, h),
            found: (f.width(), f.height()),
        });
    }

    let mut out = Vec::new();
    {
        let mut encoder = gif::Encoder::new(&mut out, w16, h16, &[])?;
        encoder.set_repeat(gif::Repeat::Infinite)?;
        for (i, pixmap) in frames.iter().enumerate() {
            let mut rgba = straight_rgba(pixmap);
            let mut frame = gif::Frame::from_rgba_speed(w16, h16, &mut rgba, GIF_SPEED);
            frame.delay = if i + 1 == frames.len() {
                delay_centiseconds.saturating_mul(LAST_FRAME_HOLD)
            } else {
                delay_centiseconds
            };
            encoder.write_frame(&frame)?;
        }
    }
    Ok(out)
}

/// Writes an animated GIF (see [`gif_bytes`]) to `path` atomically.
pub fn write_gif(
    path: &Path,
    frames: &[Pixmap],
    delay_centiseconds: u16,
) -> Result<(), RenderError> {
    write_atomic(path, &gif_bytes(frames, delay_centiseconds)?)
}

/// The pixels as straight (not premultiplied) RGBA bytes, as GIF wants.
fn straight_rgba(p: &Pixmap) -> Vec<u8> {
    p.pixels()
        .iter()
        .flat_map(|px| {
            let c = px.demultiply();
            [c.red(), c.green(), c.blue(), c.alpha()]
        })
        .collect()
}

/// The project's atomic write (temporary sibling, then rename).
fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), RenderError> {
    Ok(crate::mesh::file::write_atomic(path, bytes)?)
}
