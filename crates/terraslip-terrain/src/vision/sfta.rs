//! chen2023 §3.2.1: segmentation-based fractal texture analysis (SFTA).
//! Multi-level Otsu thresholds split the grey image into `2·n_t` binary
//! images (eq. 19-20); each gives the box-counting dimension of its border
//! map (eq. 21), its pixel share and its mean grey level.

/// `n_t` thresholds maximising the between-class variance of a 256-bin
/// grey histogram (multi-level Otsu, exact, by dynamic programming over
/// the grey levels: O(n_t·256²) instead of Liao's O(256^n_t) search).
/// Class `j` holds levels `(T_j, T_{j+1}]`, with `T_0 = -1`, `T_{n_t+1} = 255`.
pub fn multi_otsu(hist: &[u64; 256], n_t: usize) -> Vec<u8> {
    const L: usize = 256;
    let n_t = n_t.clamp(1, 8);
    let mut p = [0.0f64; L + 1];
    let mut s = [0.0f64; L + 1];
    for i in 0..L {
        p[i + 1] = p[i] + hist[i] as f64;
        s[i + 1] = s[i] + i as f64 * hist[i] as f64;
    }
    // Between-class variance is Σ_j S_j²/P_j up to constants.
    let cost = |a: usize, b: usize| -> f64 {
        let w = p[b] - p[a];
        if w > 0.0 {
            let m = s[b] - s[a];
            m * m / w
        } else {
            0.0
        }
    };
    let classes = n_t + 1;
    // best[c][e]: best value splitting levels [0, e) into c+1 classes.
    let mut best = vec![[f64::NEG_INFINITY; L + 1]; classes];
    let mut arg = vec![[0usize; L + 1]; classes];
    for (e, b) in best[0].iter_mut().enumerate().skip(1) {
        *b = cost(0, e);
    }
    for c in 1..classes {
        for e in (c + 1)..=L {
            for b in c..e {
                let v = best[c - 1][b] + cost(b, e);
                if v > best[c][e] {
                    best[c][e] = v;
                    arg[c][e] = b;
                }
            }
        }
    }
    let mut cuts = vec![0usize; n_t];
    let mut e = L;
    for c in (1..classes).rev() {
        let b = arg[c][e];
        cuts[c - 1] = b;
        e = b;
    }
    // A cut at b means class boundary between levels b-1 and b: T = b-1.
    cuts.iter().map(|&b| b.saturating_sub(1) as u8).collect()
}

/// Appends SFTA features of a grey image (chen2023): for each of the
/// `2·n_t` binary images, [box-counting dimension of its border, share of
/// pixels in it, their mean grey level].
pub fn sfta(grey: &[u8], width: usize, height: usize, n_t: usize, out: &mut Vec<f64>) {
    let n_t = n_t.clamp(1, 8);
    let n_img = 2 * n_t;
    let n_px = width * height;
    if n_px == 0 || grey.len() < n_px {
        out.resize(out.len() + 3 * n_img, 0.0);
        return;
    }
    let grey = &grey[..n_px];
    let mut hist = [0u64; 256];
    for &g in grey {
        hist[g as usize] += 1;
    }
    let thr = multi_otsu(&hist, n_t);
    // label(g) = number of thresholds below g: 0..=n_t.
    let mut label_of = [0u8; 256];
    for (g, l) in label_of.iter_mut().enumerate() {
        *l = thr.iter().filter(|&&t| g > t as usize).count() as u8;
    }
    let labels: Vec<u8> = grey.iter().map(|&g| label_of[g as usize]).collect();
    // 3x3 min and max of labels (edge pixels see only existing neighbours).
    let (mn, mx) = min_max_3x3(&labels, width, height);
    // Membership and border bitmasks of the 2·n_t binary images:
    // bit i < n_t: levels [0, T_{i+1}] (label <= i);
    // bit n_t + j: levels (T_{j+1}, T_{j+2}] (label == j + 1).
    let mut member_mask = [0u16; 9];
    for (l, m) in member_mask.iter_mut().enumerate().take(n_t + 1) {
        for i in 0..n_t {
            if l <= i {
                *m |= 1 << i;
            }
        }
        if l >= 1 {
            *m |= 1 << (n_t + l - 1);
        }
    }
    // Border mask of every binary image as a function of (label, 3x3 min,
    // 3x3 max): a table of at most 9³ entries, one lookup per pixel.
    let nl = n_t + 1;
    let mut border_of = vec![0u16; nl * nl * nl];
    for l in 0..nl {
        for lo in 0..nl {
            for hi in 0..nl {
                let mut b = 0u16;
                for i in 0..n_t {
                    // Cumulative set {label <= i}: border if a neighbour is above i.
                    if l <= i && hi > i {
                        b |= 1 << i;
                    }
                }
                if l >= 1 && (lo < l || hi > l) {
                    b |= 1 << (n_t + l - 1);
                }
                border_of[(l * nl + lo) * nl + hi] = b;
            }
        }
    }
    let border: Vec<u16> = labels
        .iter()
        .zip(mn.iter().zip(&mx))
        .map(|(&l, (&lo, &hi))| border_of[(l as usize * nl + lo as usize) * nl + hi as usize])
        .collect();
    // Pixel counts and grey sums per label, then per binary image.
    let mut label_count = [0u64; 9];
    let mut label_grey = [0u64; 9];
    for (&l, &g) in labels.iter().zip(grey) {
        label_count[l as usize] += 1;
        label_grey[l as usize] += g as u64;
    }
    let mut count = [0u64; 16];
    let mut grey_sum = [0u64; 16];
    for (l, m) in member_mask.iter().enumerate().take(nl) {
        for i in 0..n_img {
            if m & (1 << i) != 0 {
                count[i] += label_count[l];
                grey_sum[i] += label_grey[l];
            }
        }
    }
    let dims = box_counting(border, width, height, n_img);
    for i in 0..n_img {
        out.push(dims[i]);
        out.push(count[i] as f64 / n_px as f64);
        out.push(if count[i] > 0 {
            grey_sum[i] as f64 / count[i] as f64
        } else {
            0.0
        });
    }
}

fn min_max_3x3(v: &[u8], w: usize, h: usize) -> (Vec<u8>, Vec<u8>) {
    // Separable: 1x3 along rows, then 3x1 along columns; edges see only
    // the neighbours that exist.
    let mut rmin = vec![0u8; v.len()];
    let mut rmax = vec![0u8; v.len()];
    for y in 0..h {
        let row = &v[y * w..(y + 1) * w];
        let (omin, omax) = (&mut rmin[y * w..(y + 1) * w], &mut rmax[y * w..(y + 1) * w]);
        for x in 0..w {
            let a = row[x.saturating_sub(1)];
            let b = row[x];
            let c = row[(x + 1).min(w - 1)];
            omin[x] = a.min(b).min(c);
            omax[x] = a.max(b).max(c);
        }
    }
    let mut mn = vec![0u8; v.len()];
    let mut mx = vec![0u8; v.len()];
    for y in 0..h {
        let (ya, yb) = (y.saturating_sub(1), (y + 1).min(h - 1));
        let (a0, b0, c0) = (
            &rmin[ya * w..ya * w + w],
            &rmin[y * w..y * w + w],
            &rmin[yb * w..yb * w + w],
        );
        let (a1, b1, c1) = (
            &rmax[ya * w..ya * w + w],
            &rmax[y * w..y * w + w],
            &rmax[yb * w..yb * w + w],
        );
        let (omin, omax) = (&mut mn[y * w..(y + 1) * w], &mut mx[y * w..(y + 1) * w]);
        for x in 0..w {
            omin[x] = a0[x].min(b0[x]).min(c0[x]);
            omax[x] = a1[x].max(b1[x]).max(c1[x]);
        }
    }
    (mn, mx)
}

/// Box-counting dimension of each bit-plane of `mask`: boxes of side
/// 1, 2, 4, ... pixels; `D = −slope` of `ln N(s)` against `ln s`.
fn box_counting(mut mask: Vec<u16>, mut w: usize, mut h: usize, planes: usize) -> Vec<f64> {
    let mut pts: Vec<Vec<(f64, f64)>> = vec![Vec::new(); planes];
    let mut size = 1.0f64;
    let mut by_value = vec![0u32; 1 << planes.min(16)];
    loop {
        // Count cells by mask value, then spread the values over their bits:
        // one increment per cell instead of one per set bit.
        by_value.iter_mut().for_each(|c| *c = 0);
        for &m in &mask {
            by_value[m as usize] += 1;
        }
        let mut n = [0u64; 16];
        for (v, &c) in by_value.iter().enumerate().skip(1) {
            if c > 0 {
                let mut m = v;
                while m != 0 {
                    n[m.trailing_zeros() as usize] += c as u64;
                    m &= m - 1;
                }
            }
        }
        for (i, p) in pts.iter_mut().enumerate() {
            if n[i] > 0 {
                p.push((size.ln(), (n[i] as f64).ln()));
            }
        }
        if w <= 1 && h <= 1 {
            break;
        }
        let (nw, nh) = (w.div_ceil(2), h.div_ceil(2));
        let mut next = vec![0u16; nw * nh];
        for y in 0..h {
            let row = &mask[y * w..(y + 1) * w];
            let out = &mut next[(y / 2) * nw..(y / 2 + 1) * nw];
            for (x, &m) in row.iter().enumerate() {
                out[x >> 1] |= m;
            }
        }
        mask = next;
        w = nw;
        h = nh;
        size *= 2.0;
    }
    pts.iter()
        .map(|p| {
            if p.len() < 2 {
                return 0.0;
            }
            let n = p.len() as f64;
            let mx = p.iter().map(|q| q.0).sum::<f64>() / n;
            let my = p.iter().map(|q| q.1).sum::<f64>() / n;
            let sxy: f64 = p.iter().map(|q| (q.0 - mx) * (q.1 - my)).sum();
            let sxx: f64 = p.iter().map(|q| (q.0 - mx) * (q.0 - mx)).sum();
            if sxx > 0.0 {
                -sxy / sxx
            } else {
                0.0
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn otsu_finds_the_gaps_between_grey_clusters() {
        let mut h = [0u64; 256];
        for (c, w) in [(20usize, 100u64), (90, 80), (160, 120), (230, 90)] {
            for d in 0..5 {
                h[c + d] += w;
            }
        }
        let t = multi_otsu(&h, 3);
        assert_eq!(t.len(), 3);
        assert!((24..90).contains(&(t[0] as usize)), "{t:?}");
        assert!((94..160).contains(&(t[1] as usize)), "{t:?}");
        assert!((164..230).contains(&(t[2] as usize)), "{t:?}");
    }

    #[test]
    fn box_dimension_of_a_line_and_a_filled_square() {
        let (w, h) = (64, 64);
        let mut m = vec![0u16; w * h];
        for x in 0..w {
            m[32 * w + x] |= 1;
        }
        for v in m.iter_mut() {
            *v |= 2;
        }
        let d = box_counting(m, w, h, 2);
        assert!((d[0] - 1.0).abs() < 0.05, "line {d:?}");
        assert!((d[1] - 2.0).abs() < 0.05, "plane {d:?}");
    }
}
