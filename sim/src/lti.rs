//! Linear time-invariant state-space models (continuous and discrete) on nalgebra `DMatrix<f64>`.
//!
//! Conventions: continuous `ẋ = A x + B u`, `y = C x + D u`; discrete
//! `y[k] = C x[k] + D u[k]`, `x[k+1] = A x[k] + B u[k]` (so [`DiscreteLti::step`] returns the output for the
//! *current* state and input, then advances the state). Discretisation is zero-order hold through the
//! matrix exponential of the augmented matrix `[[A, B], [0, 0]]·dt` (nalgebra 0.33 `DMatrix::exp`, a
//! scaling-and-squaring Padé implementation).

use nalgebra::{Complex, DMatrix, DVector};
use serde::{Deserialize, Serialize};

use crate::error::SimError;

/// Maximum state dimension for which the allocation-free SISO step is used.
const STACK_STATES: usize = 16;

fn check_finite(what: &'static str, m: &DMatrix<f64>) -> Result<(), SimError> {
    if m.iter().all(|v| v.is_finite()) {
        Ok(())
    } else {
        Err(SimError::Numerical {
            what,
            detail: "matrix contains NaN or infinity".into(),
        })
    }
}

fn check_dims(
    a: &DMatrix<f64>,
    b: &DMatrix<f64>,
    c: &DMatrix<f64>,
    d: &DMatrix<f64>,
) -> Result<(), SimError> {
    let n = a.nrows();
    if a.ncols() != n {
        return Err(SimError::DimensionMismatch {
            what: "A columns (A must be square)",
            expected: n,
            found: a.ncols(),
        });
    }
    if b.nrows() != n {
        return Err(SimError::DimensionMismatch {
            what: "B rows",
            expected: n,
            found: b.nrows(),
        });
    }
    if c.ncols() != n {
        return Err(SimError::DimensionMismatch {
            what: "C columns",
            expected: n,
            found: c.ncols(),
        });
    }
    if d.nrows() != c.nrows() {
        return Err(SimError::DimensionMismatch {
            what: "D rows",
            expected: c.nrows(),
            found: d.nrows(),
        });
    }
    if d.ncols() != b.ncols() {
        return Err(SimError::DimensionMismatch {
            what: "D columns",
            expected: b.ncols(),
            found: d.ncols(),
        });
    }
    check_finite("A", a)?;
    check_finite("B", b)?;
    check_finite("C", c)?;
    check_finite("D", d)?;
    Ok(())
}

/// Continuous-time LTI model `ẋ = A x + B u`, `y = C x + D u`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ContinuousLti {
    /// State matrix (n × n).
    pub a: DMatrix<f64>,
    /// Input matrix (n × m).
    pub b: DMatrix<f64>,
    /// Output matrix (p × n).
    pub c: DMatrix<f64>,
    /// Feed-through matrix (p × m).
    pub d: DMatrix<f64>,
}

impl ContinuousLti {
    /// Build a model, checking that dimensions agree and every entry is finite.
    pub fn new(
        a: DMatrix<f64>,
        b: DMatrix<f64>,
        c: DMatrix<f64>,
        d: DMatrix<f64>,
    ) -> Result<Self, SimError> {
        check_dims(&a, &b, &c, &d)?;
        Ok(Self { a, b, c, d })
    }

    /// SISO model from a transfer function `num(s)/den(s)`, coefficients in *descending* powers of `s`
    /// (MATLAB `tf` order). Controllable canonical form; `deg num <= deg den` required. A pure gain
    /// (`den` of degree 0) gives a model with zero states.
    ///
    /// ```
    /// use millcomp_sim::lti::ContinuousLti;
    /// // ωn² / (s² + 2ζωn s + ωn²) with ζ = 0.5, ωn = 10 rad/s
    /// let g = ContinuousLti::from_transfer_function(&[100.0], &[1.0, 10.0, 100.0]).unwrap();
    /// assert!((g.dc_gain().unwrap()[(0, 0)] - 1.0).abs() < 1e-12);
    /// ```
    pub fn from_transfer_function(num: &[f64], den: &[f64]) -> Result<Self, SimError> {
        // strip leading zeros of the denominator/numerator
        let den: Vec<f64> = den.iter().copied().skip_while(|v| *v == 0.0).collect();
        let num: Vec<f64> = num.iter().copied().skip_while(|v| *v == 0.0).collect();
        if den.is_empty() {
            return Err(SimError::InvalidParameter {
                name: "den",
                value: 0.0,
                allowed: "a polynomial with a non-zero coefficient",
            });
        }
        if den.iter().chain(num.iter()).any(|v| !v.is_finite()) {
            return Err(SimError::Numerical {
                what: "transfer function coefficients",
                detail: "NaN or infinity".into(),
            });
        }
        let n = den.len() - 1;
        if num.len() > den.len() {
            return Err(SimError::DimensionMismatch {
                what: "numerator degree (must be <= denominator degree)",
                expected: n,
                found: num.len() - 1,
            });
        }
        let a0 = den[0];
        let den_n: Vec<f64> = den.iter().map(|v| v / a0).collect();
        // numerator padded to n+1 coefficients, normalised
        let mut num_n = vec![0.0; n + 1 - num.len()];
        num_n.extend(num.iter().map(|v| v / a0));
        let d0 = num_n[0];
        let mut a = DMatrix::zeros(n, n);
        let mut b = DMatrix::zeros(n, 1);
        let mut c = DMatrix::zeros(1, n);
        if n > 0 {
            // states x1..xn with x1 the highest derivative: ẋ1 = -a1 x1 - ... - an xn + u
            for j in 0..n {
                a[(0, j)] = -den_n[j + 1];
            }
            for i in 1..n {
                a[(i, i - 1)] = 1.0;
            }
            b[(0, 0)] = 1.0;
            for j in 0..n {
                c[(0, j)] = num_n[j + 1] - d0 * den_n[j + 1];
            }
        }
        let d = DMatrix::from_element(1, 1, d0);
        Self::new(a, b, c, d)
    }

    /// Number of states.
    pub fn n_states(&self) -> usize {
        self.a.nrows()
    }

    /// Number of inputs.
    pub fn n_inputs(&self) -> usize {
        self.b.ncols()
    }

    /// Number of outputs.
    pub fn n_outputs(&self) -> usize {
        self.c.nrows()
    }

    /// Steady-state gain `D − C A⁻¹ B` (p × m). Error if `A` is singular (integrator in the model).
    pub fn dc_gain(&self) -> Result<DMatrix<f64>, SimError> {
        if self.n_states() == 0 {
            return Ok(self.d.clone());
        }
        let lu = self.a.clone().lu();
        let x = lu.solve(&self.b).ok_or_else(|| SimError::Numerical {
            what: "dc_gain",
            detail: "A is singular (pure integrator): no finite DC gain".into(),
        })?;
        Ok(&self.d - &self.c * x)
    }

    /// Eigenvalues of `A` (the poles), in no particular order.
    pub fn poles(&self) -> Vec<Complex<f64>> {
        if self.n_states() == 0 {
            return Vec::new();
        }
        self.a.complex_eigenvalues().iter().copied().collect()
    }

    /// Zero-order-hold discretisation at sample time `dt_s` via `expm([[A, B], [0, 0]]·dt)`.
    ///
    /// ```
    /// use millcomp_sim::lti::ContinuousLti;
    /// // first-order lag 1/(τ s + 1), τ = 1 ms, sampled at 0.1 ms: pole exp(-0.1)
    /// let g = ContinuousLti::from_transfer_function(&[1.0], &[1e-3, 1.0]).unwrap();
    /// let gd = g.discretize_zoh(1e-4).unwrap();
    /// assert!((gd.a[(0, 0)] - (-0.1f64).exp()).abs() < 1e-12);
    /// ```
    pub fn discretize_zoh(&self, dt_s: f64) -> Result<DiscreteLti, SimError> {
        crate::error::check_positive("dt_s", dt_s)?;
        let n = self.n_states();
        let m = self.n_inputs();
        let mut aug = DMatrix::zeros(n + m, n + m);
        aug.view_mut((0, 0), (n, n)).copy_from(&(&self.a * dt_s));
        aug.view_mut((0, n), (n, m)).copy_from(&(&self.b * dt_s));
        let e = if n + m == 0 { aug } else { aug.exp() };
        let ad = e.view((0, 0), (n, n)).into_owned();
        let bd = e.view((0, n), (n, m)).into_owned();
        check_finite("discretised A", &ad)?;
        check_finite("discretised B", &bd)?;
        Ok(DiscreteLti {
            a: ad,
            b: bd,
            c: self.c.clone(),
            d: self.d.clone(),
            dt_s,
        })
    }

    /// Series connection `other ∘ self` (the output of `self` feeds `other`): `y = other(self(u))`.
    pub fn series(&self, other: &ContinuousLti) -> Result<ContinuousLti, SimError> {
        if other.n_inputs() != self.n_outputs() {
            return Err(SimError::DimensionMismatch {
                what: "series: inputs of second system",
                expected: self.n_outputs(),
                found: other.n_inputs(),
            });
        }
        let (n1, n2) = (self.n_states(), other.n_states());
        let m = self.n_inputs();
        let p = other.n_outputs();
        let mut a = DMatrix::zeros(n1 + n2, n1 + n2);
        a.view_mut((0, 0), (n1, n1)).copy_from(&self.a);
        a.view_mut((n1, 0), (n2, n1))
            .copy_from(&(&other.b * &self.c));
        a.view_mut((n1, n1), (n2, n2)).copy_from(&other.a);
        let mut b = DMatrix::zeros(n1 + n2, m);
        b.view_mut((0, 0), (n1, m)).copy_from(&self.b);
        b.view_mut((n1, 0), (n2, m))
            .copy_from(&(&other.b * &self.d));
        let mut c = DMatrix::zeros(p, n1 + n2);
        c.view_mut((0, 0), (p, n1)).copy_from(&(&other.d * &self.c));
        c.view_mut((0, n1), (p, n2)).copy_from(&other.c);
        let d = &other.d * &self.d;
        ContinuousLti::new(a, b, c, d)
    }

    /// Unity negative feedback of a SISO loop `L = self`: closed loop `L/(1+L)` (requires `1 + D ≠ 0`).
    pub fn unity_feedback(&self) -> Result<ContinuousLti, SimError> {
        if self.n_inputs() != 1 || self.n_outputs() != 1 {
            return Err(SimError::DimensionMismatch {
                what: "unity_feedback: SISO loop required (inputs)",
                expected: 1,
                found: self.n_inputs(),
            });
        }
        let d = self.d[(0, 0)];
        let den = 1.0 + d;
        if den.abs() < 1e-14 {
            return Err(SimError::Numerical {
                what: "unity_feedback",
                detail: "algebraic loop 1 + D = 0".into(),
            });
        }
        // u = r - y, y = C x + D u  =>  y = (C x + D r)/(1+D)
        let a = &self.a - &self.b * &self.c / den;
        let b = &self.b / den;
        let c = &self.c / den;
        let dd = DMatrix::from_element(1, 1, d / den);
        ContinuousLti::new(a, b, c, dd)
    }
}

/// Discrete-time LTI model `y[k] = C x[k] + D u[k]`, `x[k+1] = A x[k] + B u[k]`, sample time `dt_s`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DiscreteLti {
    /// State matrix.
    pub a: DMatrix<f64>,
    /// Input matrix.
    pub b: DMatrix<f64>,
    /// Output matrix.
    pub c: DMatrix<f64>,
    /// Feed-through matrix.
    pub d: DMatrix<f64>,
    /// Sample time (s).
    pub dt_s: f64,
}

impl DiscreteLti {
    /// Build a discrete model, checking dimensions, finiteness and `dt_s > 0`.
    pub fn new(
        a: DMatrix<f64>,
        b: DMatrix<f64>,
        c: DMatrix<f64>,
        d: DMatrix<f64>,
        dt_s: f64,
    ) -> Result<Self, SimError> {
        check_dims(&a, &b, &c, &d)?;
        crate::error::check_positive("dt_s", dt_s)?;
        Ok(Self { a, b, c, d, dt_s })
    }

    /// Number of states.
    pub fn n_states(&self) -> usize {
        self.a.nrows()
    }

    /// Number of inputs.
    pub fn n_inputs(&self) -> usize {
        self.b.ncols()
    }

    /// Number of outputs.
    pub fn n_outputs(&self) -> usize {
        self.c.nrows()
    }

    /// The same plant seen every `steps` samples with the input held over them: `A^steps`,
    /// `Σ_{i<steps} A^i B`, the same `C` and `D`, sample time `steps · dt_s` — for a zero-order hold this
    /// is the model discretised at the longer period, exactly (one step: a copy).
    ///
    /// # Errors
    /// [`SimError::InvalidParameter`] for `steps = 0`.
    ///
    /// # Examples
    /// ```
    /// use millcomp_sim::ContinuousLti;
    /// let c = ContinuousLti::from_transfer_function(&[1.0], &[1e-3, 1.0]).unwrap();
    /// let (fine, coarse) = (c.discretize_zoh(5e-5).unwrap(), c.discretize_zoh(5e-4).unwrap());
    /// let held = fine.held_over(10).unwrap();
    /// assert!((held.a[(0, 0)] - coarse.a[(0, 0)]).abs() < 1e-12);
    /// assert!((held.b[(0, 0)] - coarse.b[(0, 0)]).abs() < 1e-12 * coarse.b[(0, 0)].abs());
    /// assert!((held.dt_s - 5e-4).abs() < 1e-15);
    /// ```
    pub fn held_over(&self, steps: usize) -> Result<Self, SimError> {
        if steps == 0 {
            return Err(SimError::InvalidParameter {
                name: "steps",
                value: 0.0,
                allowed: "steps >= 1",
            });
        }
        let mut a = DMatrix::<f64>::identity(self.n_states(), self.n_states());
        let mut b = DMatrix::<f64>::zeros(self.n_states(), self.n_inputs());
        for _ in 0..steps {
            b = &self.a * &b + &self.b;
            a = &self.a * &a;
        }
        Self::new(
            a,
            b,
            self.c.clone(),
            self.d.clone(),
            self.dt_s * steps as f64,
        )
    }

    /// A zero state vector of the right size.
    pub fn zero_state(&self) -> DVector<f64> {
        DVector::zeros(self.n_states())
    }

    /// State that is in equilibrium for the constant input `u`: `x = (I − A)⁻¹ B u`.
    pub fn steady_state(&self, u: &DVector<f64>) -> Result<DVector<f64>, SimError> {
        let n = self.n_states();
        let m = DMatrix::<f64>::identity(n, n) - &self.a;
        m.lu()
            .solve(&(&self.b * u))
            .ok_or_else(|| SimError::Numerical {
                what: "steady_state",
                detail: "I − A singular (integrator)".into(),
            })
    }

    /// One step: returns `y[k] = C x[k] + D u[k]` and advances `state` to `x[k+1] = A x[k] + B u[k]`.
    pub fn step(&self, state: &mut DVector<f64>, u: &DVector<f64>) -> DVector<f64> {
        let y = &self.c * &*state + &self.d * u;
        let next = &self.a * &*state + &self.b * u;
        *state = next;
        y
    }

    /// SISO step without heap allocation for up to 16 states (first input, first output).
    ///
    /// ```
    /// use millcomp_sim::lti::ContinuousLti;
    /// let g = ContinuousLti::from_transfer_function(&[1.0], &[1e-3, 1.0]).unwrap();
    /// let gd = g.discretize_zoh(1e-4).unwrap();
    /// let mut x = gd.zero_state();
    /// let mut y = 0.0;
    /// for _ in 0..1000 { y = gd.step_siso(&mut x, 1.0); }
    /// assert!((y - 1.0).abs() < 1e-9); // settles to the DC gain
    /// ```
    pub fn step_siso(&self, state: &mut DVector<f64>, u: f64) -> f64 {
        let n = self.n_states();
        let mut y = self.d[(0, 0)] * u;
        for j in 0..n {
            y += self.c[(0, j)] * state[j];
        }
        if n <= STACK_STATES {
            let mut next = [0.0f64; STACK_STATES];
            for (i, nx) in next.iter_mut().enumerate().take(n) {
                let mut acc = self.b[(i, 0)] * u;
                for j in 0..n {
                    acc += self.a[(i, j)] * state[j];
                }
                *nx = acc;
            }
            for i in 0..n {
                state[i] = next[i];
            }
        } else {
            let next = &self.a * &*state + self.b.column(0) * u;
            *state = next;
        }
        y
    }

    /// Steady-state gain `C (I − A)⁻¹ B + D`.
    pub fn dc_gain(&self) -> Result<DMatrix<f64>, SimError> {
        let n = self.n_states();
        if n == 0 {
            return Ok(self.d.clone());
        }
        let m = DMatrix::<f64>::identity(n, n) - &self.a;
        let x = m.lu().solve(&self.b).ok_or_else(|| SimError::Numerical {
            what: "dc_gain",
            detail: "I − A singular (integrator): no finite DC gain".into(),
        })?;
        Ok(&self.c * x + &self.d)
    }

    /// Simulate a SISO response to the input sequence `u` from the zero state.
    pub fn simulate_siso(&self, u: &[f64]) -> Vec<f64> {
        let mut x = self.zero_state();
        u.iter().map(|&uk| self.step_siso(&mut x, uk)).collect()
    }
}

/// Step-response figures of a SISO response sampled uniformly.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct StepFigures {
    /// Final value used as reference (last sample).
    pub final_value: f64,
    /// Overshoot in percent of the final value (0 if none).
    pub overshoot_pct: f64,
    /// Time from 0 to the first crossing of 90 % of the final value (s), linearly interpolated.
    pub rise_time_0_90_s: f64,
    /// Time from 10 % to 90 % (s).
    pub rise_time_10_90_s: f64,
}

/// Overshoot and rise times of a sampled step response `y` (sample spacing `dt_s`, `y[0]` at t = 0).
/// The final value is the mean of the last 5 % of samples; returns `None` if it is ~0 or a threshold is
/// never crossed.
pub fn step_figures(y: &[f64], dt_s: f64) -> Option<StepFigures> {
    if y.len() < 20 {
        return None;
    }
    let tail = (y.len() / 20).max(1);
    let fv: f64 = y[y.len() - tail..].iter().sum::<f64>() / tail as f64;
    if !fv.is_finite() || fv.abs() < 1e-15 {
        return None;
    }
    let yn: Vec<f64> = y.iter().map(|v| v / fv).collect();
    let cross = |level: f64| -> Option<f64> {
        for k in 1..yn.len() {
            if yn[k] >= level && yn[k - 1] < level {
                let frac = (level - yn[k - 1]) / (yn[k] - yn[k - 1]);
                return Some((k as f64 - 1.0 + frac) * dt_s);
            }
        }
        None
    };
    let t90 = cross(0.9)?;
    let t10 = cross(0.1)?;
    let peak = yn.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    Some(StepFigures {
        final_value: fv,
        overshoot_pct: ((peak - 1.0) * 100.0).max(0.0),
        rise_time_0_90_s: t90,
        rise_time_10_90_s: t90 - t10,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn second_order_canonical_form_dc_and_poles() {
        // ζ = 0.5, ωn = 10: poles -5 ± j 8.660 (analytic)
        let g = ContinuousLti::from_transfer_function(&[100.0], &[1.0, 10.0, 100.0]).unwrap();
        let mut p = g.poles();
        p.sort_by(|a, b| a.im.partial_cmp(&b.im).unwrap());
        assert_relative_eq!(p[0].re, -5.0, epsilon = 1e-10);
        assert_relative_eq!(p[1].im, 75f64.sqrt(), epsilon = 1e-10);
        assert_relative_eq!(g.dc_gain().unwrap()[(0, 0)], 1.0, epsilon = 1e-12);
    }

    #[test]
    fn zoh_matches_analytic_first_order() {
        // 1/(s+a): Ad = e^{-a dt}, Bd = (1 - e^{-a dt})/a (analytic ZOH)
        let a = 300.0;
        let dt = 1e-3;
        let g = ContinuousLti::from_transfer_function(&[1.0], &[1.0, a]).unwrap();
        let gd = g.discretize_zoh(dt).unwrap();
        assert_relative_eq!(gd.a[(0, 0)], (-a * dt).exp(), epsilon = 1e-13);
        assert_relative_eq!(gd.b[(0, 0)], (1.0 - (-a * dt).exp()) / a, epsilon = 1e-13);
        assert_relative_eq!(
            gd.dc_gain().unwrap()[(0, 0)],
            g.dc_gain().unwrap()[(0, 0)],
            epsilon = 1e-12
        );
    }

    #[test]
    fn zoh_step_response_exact_at_samples() {
        // 2nd-order step at sample instants equals the analytic continuous step response (ZOH is exact
        // for piecewise-constant inputs). ζ = 0.46, ωn = 1302 rad/s (000 §5.2.4 values).
        let (z, wn) = (0.46f64, 1302.0f64);
        let g = ContinuousLti::from_transfer_function(&[wn * wn], &[1.0, 2.0 * z * wn, wn * wn])
            .unwrap();
        let dt = 5e-5;
        let gd = g.discretize_zoh(dt).unwrap();
        let y = gd.simulate_siso(&vec![1.0; 200]);
        let wd = wn * (1.0 - z * z).sqrt();
        let phi = (1.0 - z * z).sqrt().atan2(z);
        for (k, yk) in y.iter().enumerate() {
            let t = k as f64 * dt;
            let exact = 1.0 - (-z * wn * t).exp() / (1.0 - z * z).sqrt() * (wd * t + phi).sin();
            assert_relative_eq!(*yk, exact, epsilon = 1e-10);
        }
        let f = step_figures(&gd.simulate_siso(&vec![1.0; 4000]), dt).unwrap();
        // analytic overshoot exp(-πζ/√(1-ζ²)) = 19.6 %
        assert_relative_eq!(
            f.overshoot_pct,
            100.0 * (-std::f64::consts::PI * z / (1.0 - z * z).sqrt()).exp(),
            epsilon = 0.05
        );
    }

    #[test]
    fn biproper_transfer_function_has_feedthrough() {
        // (s + 2)/(s + 1) = 1 + 1/(s+1): D = 1, DC gain 2
        let g = ContinuousLti::from_transfer_function(&[1.0, 2.0], &[1.0, 1.0]).unwrap();
        assert_relative_eq!(g.d[(0, 0)], 1.0);
        assert_relative_eq!(g.dc_gain().unwrap()[(0, 0)], 2.0, epsilon = 1e-12);
    }

    #[test]
    fn series_and_feedback() {
        let g1 = ContinuousLti::from_transfer_function(&[2.0], &[1.0, 1.0]).unwrap();
        let g2 = ContinuousLti::from_transfer_function(&[3.0], &[1.0, 5.0]).unwrap();
        let s = g1.series(&g2).unwrap();
        assert_relative_eq!(
            s.dc_gain().unwrap()[(0, 0)],
            2.0 * 3.0 / 5.0,
            epsilon = 1e-12
        );
        let cl = s.unity_feedback().unwrap();
        let l = 1.2;
        assert_relative_eq!(
            cl.dc_gain().unwrap()[(0, 0)],
            l / (1.0 + l),
            epsilon = 1e-12
        );
    }

    #[test]
    fn rejects_bad_input() {
        assert!(ContinuousLti::from_transfer_function(&[1.0, 0.0, 0.0], &[1.0, 1.0]).is_err());
        assert!(ContinuousLti::from_transfer_function(&[1.0], &[0.0]).is_err());
        let g = ContinuousLti::from_transfer_function(&[1.0], &[1.0, 1.0]).unwrap();
        assert!(matches!(
            g.discretize_zoh(0.0),
            Err(SimError::InvalidParameter { name: "dt_s", .. })
        ));
        assert!(
            ContinuousLti::new(
                DMatrix::zeros(2, 2),
                DMatrix::zeros(3, 1),
                DMatrix::zeros(1, 2),
                DMatrix::zeros(1, 1)
            )
            .is_err()
        );
    }
}
