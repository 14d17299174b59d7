//! lv2019 §III-2: `D`-bin histograms of R, G and B and the histogram of
//! rotation-invariant uniform LBP codes (P = 8, R = 1).

use image::RgbImage;

/// Bins of the rotation-invariant uniform LBP histogram (P = 8: codes 0..=8
/// count the ones of uniform patterns, 9 collects the non-uniform ones).
pub const LBP_BINS: usize = 10;

/// Appends `bins` normalised histogram bins for each of R, G, B.
pub fn rgb_histograms(img: &RgbImage, bins: usize, out: &mut Vec<f64>) {
    let bins = bins.clamp(1, 256);
    let mut bin_of = [0u16; 256];
    for (v, b) in bin_of.iter_mut().enumerate() {
        *b = (v * bins / 256) as u16;
    }
    // Two interleaved copies per channel: neighbouring pixels often fall in
    // the same bin, and back-to-back increments of one counter stall.
    let mut h2 = vec![0u32; 6 * bins];
    let (h_a, h_b) = h2.split_at_mut(3 * bins);
    let raw = img.as_raw();
    let mut pairs = raw.chunks_exact(6);
    for p in &mut pairs {
        h_a[bin_of[p[0] as usize] as usize] += 1;
        h_a[bins + bin_of[p[1] as usize] as usize] += 1;
        h_a[2 * bins + bin_of[p[2] as usize] as usize] += 1;
        h_b[bin_of[p[3] as usize] as usize] += 1;
        h_b[bins + bin_of[p[4] as usize] as usize] += 1;
        h_b[2 * bins + bin_of[p[5] as usize] as usize] += 1;
    }
    for p in pairs.remainder().chunks_exact(3) {
        for c in 0..3 {
            h_a[c * bins + bin_of[p[c] as usize] as usize] += 1;
        }
    }
    let h: Vec<u32> = h_a.iter().zip(h_b.iter()).map(|(a, b)| a + b).collect();
    let n = (img.width() as f64 * img.height() as f64).max(1.0);
    out.extend(h.iter().map(|&c| c as f64 / n));
}

/// Bin of each 8-bit LBP code: the number of ones for uniform patterns
/// (at most two 0/1 transitions around the circle), 9 otherwise.
const fn lbp_table() -> [u8; 256] {
    let mut t = [0u8; 256];
    let mut code: usize = 0;
    while code < 256 {
        let rotated = ((code << 1) | (code >> 7)) & 0xff;
        let transitions = (code ^ rotated).count_ones();
        t[code] = if transitions <= 2 {
            (code as u32).count_ones() as u8
        } else {
            9
        };
        code += 1;
    }
    t
}
static LBP_TABLE: [u8; 256] = lbp_table();

/// Appends the normalised riu2 LBP histogram (P = 8, R = 1) of a grey image.
///
/// Ojala's convention: bit `p` is set when neighbour `g_p >= g_c`, with
/// `p = 0` the right neighbour and `p` increasing counter-clockwise
/// (right, up-right, up, up-left, left, down-left, down, down-right).
/// Border pixels, lacking a full neighbourhood, are skipped.
pub fn lbp_histogram(grey: &[u8], width: usize, height: usize, out: &mut Vec<f64>) {
    let mut h = [0u32; LBP_BINS];
    if width >= 3 && height >= 3 && grey.len() >= width * height {
        // One pass per neighbour over a whole row: simple zips that the
        // compiler vectorises, then one table lookup per pixel.
        let inner = width - 2;
        let mut code = vec![0u8; inner];
        for y in 1..height - 1 {
            let up = &grey[(y - 1) * width..y * width];
            let mid = &grey[y * width..(y + 1) * width];
            let down = &grey[(y + 1) * width..(y + 2) * width];
            let centre = &mid[1..width - 1];
            code.iter_mut().for_each(|c| *c = 0);
            // (row, column offset) of neighbour p, p = 0 right, counter-clockwise.
            let neighbours: [(&[u8], usize); 8] = [
                (mid, 2),
                (up, 2),
                (up, 1),
                (up, 0),
                (mid, 0),
                (down, 0),
                (down, 1),
                (down, 2),
            ];
            for (p, (row, dx)) in neighbours.iter().enumerate() {
                let nb = &row[*dx..*dx + inner];
                for ((c, &n), &g) in code.iter_mut().zip(nb).zip(centre) {
                    *c |= ((n >= g) as u8) << p;
                }
            }
            for &c in &code {
                h[LBP_TABLE[c as usize] as usize] += 1;
            }
        }
    }
    let n = h.iter().sum::<u32>().max(1) as f64;
    out.extend(h.iter().map(|&c| c as f64 / n));
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lbp_of_flat_and_striped_images() {
        // A flat image: every neighbour >= centre, code 255, bin 8.
        let flat = vec![7u8; 25];
        let mut out = Vec::new();
        lbp_histogram(&flat, 5, 5, &mut out);
        assert_eq!(out[8], 1.0);
        // A single bright pixel over a dark background: its code is 0
        // (no neighbour >= it), bin 0.
        let mut spot = vec![0u8; 9];
        spot[4] = 200;
        let mut out = Vec::new();
        lbp_histogram(&spot, 3, 3, &mut out);
        assert_eq!(out[0], 1.0);
        // A bright right neighbour only with a dark rest: Ojala's bit 0.
        let mut img = vec![100u8; 9];
        for (i, v) in img.iter_mut().enumerate() {
            if i != 4 && i != 5 {
                *v = 0;
            }
        }
        let mut out = Vec::new();
        lbp_histogram(&img, 3, 3, &mut out);
        assert_eq!(out[1], 1.0, "one bit set -> uniform, bin 1: {out:?}");
    }
}
