//! How strongly a flight excites an effect, decided before any outcome (used by the trials to
//! score recall only on flights that could show the effect).

use super::gram::{Gram, active, add_at, ar_models, fit, grams, heldout_rss, positions, set_of, system};
use super::{Options, available, gated, refine};
use crate::effects::Effect;
use crate::identify::fit::stats::{Ar, schur_complement};
use crate::identify::input::series::{Corrections, Series};
use nalgebra::{DMatrix, DVector};

/// How strongly one flight excites an effect, decided from the data's information matrix
/// and the effect's size, not from what `identify` found.
#[derive(Clone, Copy, Debug, serde::Serialize, serde::Deserialize)]
pub struct Excitation {
    /// Noncentrality of the effect's block given every other candidate:
    /// λ = θᵀ·(G_CC − G_CO·G_OO⁻¹·G_OC)·θ on the prewhitened training problem (G the whitened
    /// Gram matrix of all candidates, θ the effect's true parameters). The F-test of the block
    /// has power ≈ 95 % at the Bonferroni level 0.001 from λ ≈ 25 (one parameter) to 35 (three).
    pub lambda: f64,
    /// The share of the held-out residual energy on the channel axes the effect acts on that it
    /// makes, E/(E + N): E = θᵀ·(G_t,CC − G_t,CH·G_t,HH⁻¹·G_t,HC)·θ, the held-out energy of the
    /// part of the effect that the flight's *other hidden effects* H do not explain (G_t the raw
    /// held-out Gram over the channel axes the effect acts on; the held-out gate tests the effect on top of
    /// a model that holds them), N the held-out energy of the residual of the model with every
    /// candidate. The held-out gate needs a 10 % RMSE cut, i.e.
    /// a share of at least 19 %.
    pub heldout_share: f64,
}

impl Excitation {
    /// Enough for the selection to find the effect: λ ≥ 40 and a held-out share ≥ 0.3 (margins
    /// over the 95 %-power λ and the 19 % the held-out gate needs).
    pub fn sufficient(&self) -> bool {
        self.lambda >= 40.0 && self.heldout_share >= 0.3
    }
}

/// The excitation of each effect in `truth` (parameters in the reported units) on flight `s`,
/// at the nominal corrections (see [`Excitation`]). Effects the data has no columns for get
/// λ = 0.
pub fn excitation(s: &Series, o: &Options, truth: &[(Effect, Vec<f64>)]) -> Vec<Excitation> {
    let s = &gated(s, o, &Corrections::default());
    let mut corr = Corrections::default();
    let st = refine(s, o, &mut corr, &[], 0);
    let all: Vec<Effect> = Effect::ALL
        .iter()
        .copied()
        .filter(|e| (o.candidates.contains(e) || o.forced.contains(e)) && available(&st.design, *e))
        .collect();
    let white: Vec<Ar> = active(&st.design).iter().map(|_| Ar::white(1.0)).collect();
    let g_ols = grams(&st.design, &st.train, &st.test, &white);
    let f_all = fit(&g_ols, &set_of(&all));
    let ars = ar_models(&st.design, &st.train, &f_all.theta, o);
    let gs = grams(&st.design, &st.train, &st.test, &ars);
    let rss_full_t = heldout_rss(&gs, &f_all.theta);
    truth
        .iter()
        .map(|(e, values)| {
            if !all.contains(e) {
                return Excitation { lambda: 0.0, heldout_share: 0.0 };
            }
            let block = set_of(&[*e]);
            let others: Vec<usize> = set_of(&all).into_iter().filter(|j| !block.contains(j)).collect();
            let mut order = block.clone();
            order.extend(&others);
            let (g, _, _, _) = system(&gs, &order);
            let k = block.len();
            let theta = in_fit_units(*e, values);
            let lambda = quadratic_form(&theta, &schur_complement(&g, k));
            // held-out energy of the part of the effect that the flight's other hidden effects
            // do not explain (the Schur complement of the held-out Gram over the axes the effect
            // acts on: a thrust against voltage whose mean a hidden thrust scale takes is not
            // counted), and of the full model's residual, on those axes
            let mut order = block.clone();
            let partner_cols = set_of(&partners(truth, *e, &all));
            order.extend(&partner_cols);
            let (g_t, noise) = heldout_on_axes_of(&gs, &block, &order, &rss_full_t);
            let energy = quadratic_form(&theta, &schur_complement(&g_t, k));
            Excitation { lambda, heldout_share: share(energy, noise) }
        })
        .collect()
}

/// On the channel axes that have a column of `block` (the axes the effect acts on): the raw
/// held-out Gram of the columns `order`, summed over those axes in `order`'s order (a column an
/// axis lacks adds nothing there), and the sum of `rss_t`, each axis's held-out residual energy.
fn heldout_on_axes_of(gs: &[Gram], block: &[usize], order: &[usize], rss_t: &[f64]) -> (DMatrix<f64>, f64) {
    let mut g_t = DMatrix::<f64>::zeros(order.len(), order.len());
    let mut noise = 0.0;
    for (gr, rss) in gs.iter().zip(rss_t) {
        if gr.cols.iter().any(|j| block.contains(j)) {
            add_at(&mut g_t, &gr.g_t, &positions(order, &gr.cols));
            noise += rss;
        }
    }
    (g_t, noise)
}

/// The other effects of `truth` that the data has columns for (`all`): the hidden effects whose
/// part of the held-out Gram is projected out of `e`'s.
fn partners(truth: &[(Effect, Vec<f64>)], e: Effect, all: &[Effect]) -> Vec<Effect> {
    truth.iter().map(|(x, _)| *x).filter(|x| *x != e && all.contains(x)).collect()
}

/// An effect's parameters from the reported units (deg, ms, mm, …) to the fit's SI and radian
/// values: each over its factor in [`Effect::params`].
fn in_fit_units(e: Effect, values: &[f64]) -> DVector<f64> {
    DVector::from_iterator(e.n_params(), values.iter().zip(e.params()).map(|(v, (_, _, f))| v / f))
}

/// θᵀ·M·θ, floored at 0 (M a Schur complement, positive semidefinite up to rounding).
fn quadratic_form(theta: &DVector<f64>, m: &DMatrix<f64>) -> f64 {
    (theta.transpose() * m * theta)[(0, 0)].max(0.0)
}

/// The effect's share E/(E + N) of the held-out energy (0 when both are 0).
fn share(energy: f64, noise: f64) -> f64 {
    if energy + noise > 0.0 { energy / (energy + noise) } else { 0.0 }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The r×r matrix of `v` (row by row).
    fn m(r: usize, v: &[f64]) -> DMatrix<f64> {
        DMatrix::from_row_slice(r, r, v)
    }

    /// E/(E + N) by hand on both sides of E = N and at the ends: 1/(1 + 3) = 0.25, 3/(3 + 1) =
    /// 0.75, an effect with no residual left 1, nothing at all 0. A bug it catches: the guard's `E +
    /// N` as `E − N` (0 whenever E < N) and as `E·N` (0 when N = 0).
    #[test]
    fn the_heldout_share_by_hand() {
        assert_eq!(
            [share(1.0, 3.0), share(3.0, 1.0), share(2.0, 0.0), share(0.0, 0.0), share(0.0, 2.0)],
            [0.25, 0.75, 1.0, 0.0, 0.0]
        );
    }

    /// Reported units back to the fit's: a lever arm of 10, −5 and 2 mm is 0.01, −0.005 and 0.002
    /// m; 1° of body-offset roll is π/180 rad; a mocap delay of 5 ms is 0.005 s. A bug it catches:
    /// the value times its factor, or modulo it.
    #[test]
    fn the_true_parameters_are_taken_back_to_the_fits_units() {
        let close = |got: DVector<f64>, want: &[f64]| {
            got.len() == want.len() && got.iter().zip(want).all(|(g, w)| (g - w).abs() <= 1e-15 * w.abs().max(1.0))
        };
        assert!(close(in_fit_units(Effect::LeverArm, &[10.0, -5.0, 2.0]), &[0.01, -0.005, 0.002]));
        assert!(close(
            in_fit_units(Effect::BodyOffset, &[1.0, 0.0, -2.0]),
            &[std::f64::consts::PI / 180.0, 0.0, -std::f64::consts::PI / 90.0]
        ));
        assert!(close(in_fit_units(Effect::MocapDelay, &[5.0]), &[0.005]));
    }

    /// The partners of an effect are the other true effects the data has columns for: of {mocap
    /// delay, thrust scale, lever arm} with no lever-arm column, the mocap delay's is the thrust
    /// scale alone. A bug it catches: the `&&` as `||` (the effect its own partner, its held-out energy 0).
    #[test]
    fn an_effects_partners_are_the_other_true_effects_with_columns() {
        let truth = [
            (Effect::MocapDelay, vec![5.0]),
            (Effect::ThrustScale, vec![0.1]),
            (Effect::LeverArm, vec![10.0, 0.0, 0.0]),
        ];
        let all = [Effect::MocapDelay, Effect::ThrustScale, Effect::GyroBias];
        assert_eq!(partners(&truth, Effect::MocapDelay, &all), [Effect::ThrustScale]);
        assert_eq!(partners(&truth, Effect::ThrustScale, &all), [Effect::MocapDelay]);
    }

    /// θᵀ·M·θ by hand: θ = (1, 2) on diag(2, 2.5) is 2 + 10 = 12; θ = (1, −1) on [[2, 1], [1, 3]]
    /// is 2 − 1 − 1 + 3 = 3; a form negative by rounding is 0. A bug it catches: M + θ for M·θ (the
    /// 1×1 case is a sum, not a panic).
    #[test]
    fn the_noncentrality_is_the_quadratic_form_of_the_true_parameters() {
        assert_eq!(quadratic_form(&DVector::from_row_slice(&[1.0, 2.0]), &m(2, &[2.0, 0.0, 0.0, 2.5])), 12.0);
        assert_eq!(quadratic_form(&DVector::from_row_slice(&[1.0, -1.0]), &m(2, &[2.0, 1.0, 1.0, 3.0])), 3.0);
        assert_eq!(quadratic_form(&DVector::from_row_slice(&[3.0]), &m(1, &[2.0])), 18.0);
        assert_eq!(quadratic_form(&DVector::from_row_slice(&[1.0]), &m(1, &[-1e-17])), 0.0);
    }

    /// Both margins must hold, each at its boundary: λ ≥ 40 and a held-out share ≥ 0.3.
    #[test]
    fn sufficient_needs_both_the_noncentrality_and_the_heldout_share() {
        let ex = |lambda, heldout_share| Excitation { lambda, heldout_share }.sufficient();
        assert!(ex(40.0, 0.3) && ex(1e3, 0.9));
        assert!(!ex(39.9, 0.9), "too little noncentrality");
        assert!(!ex(1e3, 0.29), "too small a share of the held-out error");
        assert!(!ex(0.0, 0.0));
    }

    /// The held-out Gram on the effect's axes by hand. Axis A has columns 5, 2, 7 (G_t rows 1 2 3 /
    /// 2 4 5 / 3 5 6), axis B columns 7, 2 (10 20 / 20 30), axis C column 9 (100); their held-out
    /// residual energies are 1, 2, 4. For the block {2} with its partner 7 (order 2, 7), A and B
    /// count and C does not: G(2,2) = 4 + 30, G(2,7) = 5 + 20, G(7,7) = 6 + 10, column 5 (not in
    /// the order) adds nothing, and N = 1 + 2. For the block {9}: G = 100, N = 4. A bug it catches:
    /// the order lookup `==` as `!=` and the sum `+=` as `-=` (whole flights in the trials caught
    /// them).
    #[test]
    fn the_heldout_gram_sums_the_effects_axes_in_its_columns_order() {
        let gram = |cols: &[usize], g_t: DMatrix<f64>| Gram { g_t, ..Gram::zeros(cols.to_vec(), 1.0) };
        let gs = [
            gram(&[5, 2, 7], m(3, &[1.0, 2.0, 3.0, 2.0, 4.0, 5.0, 3.0, 5.0, 6.0])),
            gram(&[7, 2], m(2, &[10.0, 20.0, 20.0, 30.0])),
            gram(&[9], m(1, &[100.0])),
        ];
        let rss_t = [1.0, 2.0, 4.0];
        let (g, noise) = heldout_on_axes_of(&gs, &[2], &[2, 7], &rss_t);
        assert_eq!(g, m(2, &[34.0, 25.0, 25.0, 16.0]));
        assert_eq!(noise, 3.0);
        let (g, noise) = heldout_on_axes_of(&gs, &[9], &[9], &rss_t);
        assert_eq!((g, noise), (m(1, &[100.0]), 4.0));
    }
}
