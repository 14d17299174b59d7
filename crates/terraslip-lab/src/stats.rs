//! Distributions over worlds.

/// The `q` quantile (0..1) of the finite values of `v` (NaN when none).
pub fn quantile(v: &[f64], q: f64) -> f64 {
    let mut v: Vec<f64> = v.iter().copied().filter(|x| !x.is_nan()).collect();
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(|a, b| a.total_cmp(b));
    v[((v.len() - 1) as f64 * q).round() as usize]
}

/// `median / p90 / worst` of `v` (its maximum), with the seed of the worst.
pub fn summary(v: &[(u64, f64)]) -> String {
    let vals: Vec<f64> = v.iter().map(|x| x.1).collect();
    let worst = v
        .iter()
        .filter(|x| !x.1.is_nan())
        .max_by(|a, b| a.1.total_cmp(&b.1));
    match worst {
        Some(&(seed, w)) => format!(
            "{:8.2} {:8.2} {:8.2} (world {seed})",
            quantile(&vals, 0.5),
            quantile(&vals, 0.9),
            w
        ),
        None => "       -        -        -".into(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantiles_and_worst() {
        let v: Vec<(u64, f64)> = (1..=11).map(|k| (k, k as f64)).collect();
        assert_eq!(
            quantile(&v.iter().map(|x| x.1).collect::<Vec<_>>(), 0.5),
            6.0
        );
        assert!(summary(&v).contains("(world 11)"));
        assert!(quantile(&[f64::NAN], 0.5).is_nan());
    }
}
