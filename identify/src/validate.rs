//! Input checks shared by the targets: lengths, finiteness, monotone time, constant regressors.
//!
//! Every check names the column and the row it rejects, counted from 1 (the first value is row 1: in
//! a file, the first data row, as `millcomp-datasets` numbers rows).

use crate::error::{IdentifyError, Result};

/// Fails with [`IdentifyError::NonFinite`] at the first NaN/infinite value of `values`.
pub fn finite(column: &str, values: &[f64]) -> Result<()> {
    match values.iter().position(|v| !v.is_finite()) {
        Some(i) => Err(IdentifyError::NonFinite {
            column: column.to_string(),
            row: i + 1,
            value: values[i],
        }),
        None => Ok(()),
    }
}

/// Fails with [`IdentifyError::LengthMismatch`] unless `values.len() == expected`.
pub fn same_len(column: &str, values: &[f64], reference: &str, expected: usize) -> Result<()> {
    if values.len() == expected {
        Ok(())
    } else {
        Err(IdentifyError::LengthMismatch {
            column: column.to_string(),
            len: values.len(),
            reference: reference.to_string(),
            expected,
        })
    }
}

/// Fails with [`IdentifyError::NonMonotoneTime`] at the first row where `values` does not strictly
/// increase.
pub fn strictly_increasing(column: &str, values: &[f64]) -> Result<()> {
    for i in 1..values.len() {
        // `!(a > b)` also rejects NaN, though `finite` normally runs first.
        if values[i].partial_cmp(&values[i - 1]) != Some(std::cmp::Ordering::Greater) {
            return Err(IdentifyError::NonMonotoneTime {
                column: column.to_string(),
                row: i + 1,
                prev: values[i - 1],
                value: values[i],
            });
        }
    }
    Ok(())
}

/// Fails with [`IdentifyError::ConstantInput`] when all `values` are equal up to a relative
/// spread of 1e-12 (then no slope/time constant can be seen in them).
pub fn not_constant(column: &str, values: &[f64], parameters: &str) -> Result<()> {
    let (lo, hi) = values
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| {
            (lo.min(v), hi.max(v))
        });
    if values.is_empty() || hi - lo <= 1e-12 * hi.abs().max(lo.abs()).max(f64::MIN_POSITIVE) {
        return Err(IdentifyError::ConstantInput {
            column: column.to_string(),
            value: values.first().copied().unwrap_or(f64::NAN),
            parameters: parameters.to_string(),
        });
    }
    Ok(())
}

/// Fails with [`IdentifyError::TooFewPoints`] unless `n >= n_params + 1`.
pub fn enough_points(n: usize, n_params: usize, what: &str) -> Result<()> {
    if n > n_params {
        Ok(())
    } else {
        Err(IdentifyError::TooFewPoints {
            got: n,
            n_params,
            needed: n_params + 1,
            what: what.to_string(),
        })
    }
}

/// The square roots of `weights` (inverse variances), one per row of `y` (`n` rows); all 1 when
/// there are none.
///
/// # Errors
/// [`IdentifyError::LengthMismatch`] unless there is one weight per row,
/// [`IdentifyError::NonFinite`] for a NaN or infinite weight and
/// [`IdentifyError::InvalidParameter`] (`weights[row]`) for one that is not > 0.
pub fn sqrt_weights(weights: Option<&[f64]>, n: usize) -> Result<Vec<f64>> {
    let Some(w) = weights else {
        return Ok(vec![1.0; n]);
    };
    same_len("weights", w, "y", n)?;
    finite("weights", w)?;
    if let Some(i) = w.iter().position(|&v| v <= 0.0) {
        return Err(IdentifyError::InvalidParameter {
            name: format!("weights, row {}", i + 1),
            value: w[i],
            allowed: "> 0 (inverse variance)",
        });
    }
    Ok(w.iter().map(|v| v.sqrt()).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finite_names_row() {
        let e = finite("y_um", &[1.0, 2.0, f64::NAN]).unwrap_err();
        assert!(
            matches!(e, IdentifyError::NonFinite { row: 3, ref column, .. } if column == "y_um")
        );
        assert!(e.to_string().contains("`y_um`, row 3"));
    }

    #[test]
    fn monotone_names_row() {
        let e = strictly_increasing("t_s", &[0.0, 1.0, 1.0, 2.0]).unwrap_err();
        assert!(matches!(e, IdentifyError::NonMonotoneTime { row: 3, .. }));
        assert!(strictly_increasing("t_s", &[0.0, 1.0, 3.0]).is_ok());
    }

    #[test]
    fn constant_detected() {
        assert!(not_constant("load_n", &[2.0, 2.0, 2.0], "stiffness").is_err());
        assert!(not_constant("load_n", &[2.0, 2.0, 2.1], "stiffness").is_ok());
        assert!(not_constant("load_n", &[], "stiffness").is_err());
    }

    #[test]
    fn points() {
        assert!(enough_points(3, 3, "x").is_err());
        assert!(enough_points(4, 3, "x").is_ok());
    }
}
