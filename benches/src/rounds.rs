//! Interleaved rounds summarised for a table: medians of each side's figures, and the median
//! and range of the per-round ratios between the sides.
//!
//! `bench-cpu` and `optik bench-report` time optik and Embree in rounds, each round both sides
//! back to back. On a shared or throttled machine the absolute figures move by tens of percent
//! from one minute to the next; a ratio taken within one round compares the sides under the
//! same conditions, so the tables give the rounds' ratios, not the ratio of the medians.

/// The median of `values` (the mean of the middle two for an even count); `None` when empty.
pub fn median(values: &[f64]) -> Option<f64> {
    let mut v = values.to_vec();
    v.sort_by(f64::total_cmp);
    let n = v.len();
    match n {
        0 => None,
        _ if n % 2 == 1 => Some(v[n / 2]),
        _ => Some((v[n / 2 - 1] + v[n / 2]) / 2.0),
    }
}

/// Per-round ratios summarised: `(median, smallest, largest)`; `None` when empty.
fn summary(ratios: &[f64]) -> Option<(f64, f64, f64)> {
    let lo = ratios.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = ratios.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    median(ratios).map(|m| (m, lo, hi))
}

/// A table cell for per-round ratios: the value alone for one round, else the median and
/// the range, e.g. `1.05 (0.98–1.12)`; `-` for none.
pub fn ratio_cell(ratios: &[f64]) -> String {
    match summary(ratios) {
        None => "-".into(),
        Some((m, _, _)) if ratios.len() == 1 => format!("{m:.2}"),
        Some((m, lo, hi)) => format!("{m:.2} ({lo:.2}–{hi:.2})"),
    }
}

/// A table row's three measured cells from per-round (optik, Embree) times: each side's
/// median of `value(time)` with `digits` decimals, and [`ratio_cell`] of the rounds'
/// `ratio(optik, embree)`. Rounds without an Embree time count for optik's median only.
pub fn round_cells(
    rounds: &[(f64, Option<f64>)],
    value: impl Fn(f64) -> f64,
    ratio: impl Fn(f64, f64) -> f64,
    digits: usize,
) -> [String; 3] {
    let optik: Vec<f64> = rounds.iter().map(|&(o, _)| value(o)).collect();
    let embree: Vec<f64> = rounds.iter().filter_map(|&(_, e)| e.map(&value)).collect();
    let ratios: Vec<f64> = rounds
        .iter()
        .filter_map(|&(o, e)| e.map(|e| ratio(o, e)))
        .collect();
    let cell = |v: &[f64]| median(v).map_or("-".into(), |m| format!("{m:.digits$}"));
    [cell(&optik), cell(&embree), ratio_cell(&ratios)]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn medians_of_odd_and_even_counts() {
        assert_eq!(median(&[]), None);
        assert_eq!(median(&[3.0]), Some(3.0));
        assert_eq!(median(&[5.0, 1.0, 3.0]), Some(3.0));
        assert_eq!(median(&[4.0, 1.0, 3.0, 2.0]), Some(2.5));
    }

    #[test]
    fn ratio_cells_show_the_range_only_for_several_rounds() {
        assert_eq!(ratio_cell(&[]), "-");
        assert_eq!(ratio_cell(&[0.914]), "0.91");
        assert_eq!(ratio_cell(&[1.2, 0.8, 1.0]), "1.00 (0.80–1.20)");
    }

    #[test]
    fn round_cells_take_medians_and_leave_out_missing_peers() {
        let rounds = [(2.0, Some(4.0)), (1.0, None), (4.0, Some(2.0))];
        let cells = round_cells(&rounds, |s| 10.0 / s, |o, e| e / o, 2);
        assert_eq!(cells, ["5.00", "3.75", "1.25 (0.50–2.00)"]);
        assert_eq!(
            round_cells(&[(1.0, None)], |s| s, |o, e| o / e, 3),
            ["1.000", "-", "-"]
        );
    }
}
