//! The discrete Fourier transform the clock search correlates with: an iterative radix-2
//! Cooley–Tukey FFT on f64, written out (no SIMD dispatch), so that a search gives the same bits
//! on every x86-64 machine.
//!
//! X_k = Σ_{n<N} x_n·e^{∓2πi·kn/N} (− forward, + inverse; the inverse divides by N), N a power
//! of two.

/// In-place transform of (re, im), both of a power-of-two length.
pub(super) fn fft(re: &mut [f64], im: &mut [f64], inverse: bool) {
    let n = re.len();
    debug_assert!(n.is_power_of_two() && im.len() == n);
    // bit-reversal permutation
    let mut j = 0usize;
    for i in 1..n {
        let mut bit = n >> 1;
        while j & bit != 0 {
            j ^= bit;
            bit >>= 1;
        }
        j |= bit;
        if i < j {
            re.swap(i, j);
            im.swap(i, j);
        }
    }
    let sign = if inverse { 1.0 } else { -1.0 };
    let mut len = 2;
    while len <= n {
        let ang = sign * std::f64::consts::TAU / len as f64;
        let half = len / 2;
        for start in (0..n).step_by(len) {
            for k in 0..half {
                // the twiddle computed for each k (not by recurrence): no rounding builds up
                let (s, c) = (ang * k as f64).sin_cos();
                let (a, b) = (start + k, start + k + half);
                let (xr, xi) = (re[b] * c - im[b] * s, re[b] * s + im[b] * c);
                re[b] = re[a] - xr;
                im[b] = im[a] - xi;
                re[a] += xr;
                im[a] += xi;
            }
        }
        len <<= 1;
    }
    if inverse {
        let f = 1.0 / n as f64;
        re.iter_mut().chain(im.iter_mut()).for_each(|x| *x *= f);
    }
}

/// The spectrum of a real signal zero-padded to `n` (a power of two ≥ its length).
pub(super) fn spectrum(x: &[f64], n: usize) -> (Vec<f64>, Vec<f64>) {
    let mut re = vec![0.0; n];
    re[..x.len()].copy_from_slice(x);
    let mut im = vec![0.0; n];
    fft(&mut re, &mut im, false);
    (re, im)
}

/// The cross-correlation c_L = Σ_i a_i·b_{i+L} of two signals from their spectra (zero-padded
/// to n ≥ len(a) + len(b) − 1, so nothing wraps): IFFT(conj(A)·B), with c_L at index L mod n.
pub(super) fn correlate(a: &(Vec<f64>, Vec<f64>), b: &(Vec<f64>, Vec<f64>)) -> Vec<f64> {
    let n = a.0.len();
    let (mut re, mut im) = (vec![0.0; n], vec![0.0; n]);
    for k in 0..n {
        // conj(A)·B
        re[k] = a.0[k] * b.0[k] + a.1[k] * b.1[k];
        im[k] = a.0[k] * b.1[k] - a.1[k] * b.0[k];
    }
    fft(&mut re, &mut im, true);
    re
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The transform of 8 samples is the DFT summed by hand, and the inverse gives the samples
    /// back.
    #[test]
    fn the_fft_is_the_dft_and_inverts() {
        let x = [1.0, -2.0, 0.5, 3.0, 0.0, 1.5, -1.0, 2.0];
        let (mut re, mut im) = (x.to_vec(), vec![0.0; 8]);
        fft(&mut re, &mut im, false);
        for k in 0..8 {
            let (mut dr, mut di) = (0.0, 0.0);
            for (n, v) in x.iter().enumerate() {
                let a = -std::f64::consts::TAU * (k * n) as f64 / 8.0;
                dr += v * a.cos();
                di += v * a.sin();
            }
            assert!(
                (re[k] - dr).abs() < 1e-12 && (im[k] - di).abs() < 1e-12,
                "bin {k}: {} {} vs {dr} {di}",
                re[k],
                im[k]
            );
        }
        fft(&mut re, &mut im, true);
        for n in 0..8 {
            assert!((re[n] - x[n]).abs() < 1e-12 && im[n].abs() < 1e-12);
        }
    }

    /// c_L = Σ_i a_i·b_{i+L} by hand for a = (1, 2, 3), b = (4, 5): c_0 = 1·4 + 2·5 = 14,
    /// c_1 = 1·5 = 5, c_−1 = 2·4 + 3·5 = 23, c_−2 = 3·4 = 12.
    #[test]
    fn the_correlation_is_the_lagged_sum_by_hand() {
        let n = 8;
        let c = correlate(&spectrum(&[1.0, 2.0, 3.0], n), &spectrum(&[4.0, 5.0], n));
        let at = |l: isize| c[l.rem_euclid(n as isize) as usize];
        for (l, want) in [(0, 14.0), (1, 5.0), (-1, 23.0), (-2, 12.0), (2, 0.0), (-3, 0.0)] {
            assert!((at(l) - want).abs() < 1e-12, "lag {l}: {}", at(l));
        }
    }
}
