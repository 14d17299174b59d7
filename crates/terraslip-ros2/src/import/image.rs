//! Camera frames: raw `sensor_msgs/Image` to PNG.

use super::decoder::Decoder;
use crate::msg::Value;

pub(super) fn raw_to_png(d: &Decoder, v: &Value, data: &[u8]) -> Result<Vec<u8>, String> {
    let h = d.f(v, "height").unwrap_or(0.0) as u32;
    let w = d.f(v, "width").unwrap_or(0.0) as u32;
    let step = d.f(v, "step").unwrap_or(0.0) as usize;
    let enc = match d.get(v, "encoding") {
        Some(Value::Str(s)) => s.as_str(),
        _ => "",
    };
    let ch = match enc {
        "mono8" | "8UC1" => 1,
        "rgb8" | "bgr8" | "8UC3" => 3,
        "rgba8" | "bgra8" | "8UC4" => 4,
        _ => {
            return Err(format!(
                "image encoding `{enc}` is not supported (mono8, rgb8, bgr8, rgba8, bgra8 are)"
            ))
        }
    };
    let row = w as usize * ch;
    if w == 0 || h == 0 || step < row || data.len() < step * (h as usize - 1) + row {
        return Err(format!(
            "image {w}x{h} step {step} does not fit its {} bytes",
            data.len()
        ));
    }
    let mut px = Vec::with_capacity(row * h as usize);
    for r in 0..h as usize {
        let line = &data[r * step..r * step + row];
        if enc.starts_with("bgr") {
            for c in line.chunks_exact(ch) {
                px.extend_from_slice(&[c[2], c[1], c[0]]);
                if ch == 4 {
                    px.push(c[3]);
                }
            }
        } else {
            px.extend_from_slice(line);
        }
    }
    let color = match ch {
        1 => image::ExtendedColorType::L8,
        3 => image::ExtendedColorType::Rgb8,
        _ => image::ExtendedColorType::Rgba8,
    };
    let mut out = Vec::new();
    image::ImageEncoder::write_image(
        image::codecs::png::PngEncoder::new(&mut out),
        &px,
        w,
        h,
        color,
    )
    .map_err(|e| e.to_string())?;
    Ok(out)
}
