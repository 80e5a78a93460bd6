//! Figures at the precision of their interval: a half-width to two significant digits and its
//! value to the same decimals, as every report, note and fragment prints them.

/// Decimals that print a 95 % half-width `ci` to two significant digits (0 for a half-width of
/// 10 or more; 6 for one that is 0 or not finite).
pub(crate) fn decimals_for(ci: f64) -> usize {
    if !(ci.is_finite() && ci > 0.0) {
        return 6;
    }
    (1 - ci.log10().floor() as i64).clamp(0, 12) as usize
}

/// `value ± ci` to the precision of the interval.
pub(crate) fn with_interval(value: f64, ci: f64) -> String {
    let d = decimals_for(ci);
    format!("{value:.d$} ± {ci:.d$}")
}

/// [`with_interval`] with the value's sign always printed: "+0.054 ± 0.047".
pub(crate) fn signed_with_interval(value: f64, ci: f64) -> String {
    let d = decimals_for(ci);
    format!("{value:+.d$} ± {ci:.d$}")
}

/// One parameter as printed: "name value ± half-width unit", the half-width to two significant
/// digits and the value to the same decimals (a figure keeps the precision of its interval), or
/// "name value unit (not identifiable)" when the flight cannot back an interval, the value then
/// formatted by `num`.
pub(crate) fn param_text(p: &crate::identify::fit::select::Param, num: impl Fn(f64) -> String) -> String {
    if p.identifiable && p.ci95.is_finite() && p.ci95 > 0.0 {
        format!("{} {} {}", p.name, with_interval(p.value, p.ci95), p.unit)
    } else if p.identifiable {
        format!("{} {} ± {} {}", p.name, num(p.value), num(p.ci95), p.unit)
    } else {
        format!("{} {} {} (not identifiable)", p.name, num(p.value), p.unit)
    }
    .trim_end()
    .to_string()
}
