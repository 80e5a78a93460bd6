//! Seeded random streams: one independent stream per component and vehicle.
//!
//! A stream is a xoshiro256++ generator whose state is derived (SplitMix64) from the scenario seed,
//! a component tag and the vehicle index. Adding a vehicle or a noise source therefore never changes
//! the draws of the others, and a run is reproducible from `(scenario, seed)` alone.
//! The generator is implemented here (20 lines) so that its output can never change with a
//! dependency upgrade.
//!
//! ```
//! use flyarena::rng::{Stream, Component};
//! let mut a = Stream::new(7, Component::MocapNoise, 0);
//! let mut b = Stream::new(7, Component::MocapNoise, 0);
//! assert_eq!(a.next_u64(), b.next_u64());
//! let mut other = Stream::new(7, Component::LinkLoss, 0);
//! assert_ne!(Stream::new(7, Component::MocapNoise, 0).next_u64(), other.next_u64());
//! ```

/// The random consumers in the arena. The discriminant is part of the seed derivation: never
/// renumber, only append.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u64)]
pub enum Component {
    /// The cameras' marker noise.
    MocapNoise = 1,
    /// The mocap link's losses.
    LinkLoss = 2,
    /// The mocap link's jitter.
    LinkJitter = 3,
    /// The IMU's noise.
    ImuNoise = 4,
    /// The telemetry downlink's losses.
    TelemetryLoss = 5,
    /// The telemetry downlink's jitter.
    TelemetryJitter = 6,
    /// Per-run draws of a sweep (varied parameters and the run's seed); "vehicle" = run index.
    Sweep = 7,
    /// A hand-held trial's draws (calibration, motion, noise seed); "vehicle" = trial index.
    Handheld = 8,
    /// Errors drawn from a hand-held trial's Cramér–Rao bound; "vehicle" = trial index.
    Bound = 9,
    /// A mount and clock offset injected into a real log; "vehicle" = case index.
    Injection = 10,
}

fn splitmix64(x: &mut u64) -> u64 {
    *x = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
    let mut z = *x;
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// A xoshiro256++ stream.
#[derive(Clone, Debug)]
pub struct Stream {
    s: [u64; 4],
}

impl Stream {
    /// The stream of `component` for `vehicle` in a run of `seed` (splitmix64 of the three).
    pub fn new(seed: u64, component: Component, vehicle: usize) -> Self {
        let mut x = seed ^ (component as u64).wrapping_mul(0xD6E8_FEB8_6659_FD93);
        x ^= (vehicle as u64 + 1).wrapping_mul(0xA076_1D64_78BD_642F);
        let mut s = [0u64; 4];
        for v in &mut s {
            *v = splitmix64(&mut x);
        }
        Stream { s }
    }

    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        let s = &mut self.s;
        let result = s[0].wrapping_add(s[3]).rotate_left(23).wrapping_add(s[0]);
        let t = s[1] << 17;
        s[2] ^= s[0];
        s[3] ^= s[1];
        s[1] ^= s[2];
        s[0] ^= s[3];
        s[2] ^= t;
        s[3] = s[3].rotate_left(45);
        result
    }

    /// Uniform on [0, 1) with 53 bits of resolution.
    pub fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// True with probability `p`.
    pub fn bernoulli(&mut self, p: f64) -> bool {
        self.uniform() < p
    }

    /// Standard normal deviate, by the ziggurat method (Marsaglia & Tsang 2000, in Doornik's
    /// 2005 form with 128 layers): one 64-bit draw gives the layer (its low 7 bits) and a uniform
    /// u ∈ [−1, 1) (its high 53 bits); 97 % of draws end at the first comparison. The wedges and
    /// the tail beyond R = 3.44 take the exact rejection steps, so the deviate is exactly normal.
    /// (The polar method it replaced spent a logarithm, a square root and a division per pair,
    /// and was 6 % of the 200 Hz loop.)
    #[inline]
    pub fn normal(&mut self) -> f64 {
        let (i, u) = self.ziggurat_draw();
        if u.abs() < ZIGGURAT_RATIO[i] {
            return u * ZIGGURAT_X[i];
        }
        self.normal_slow(i, u)
    }

    /// A layer i (the low 7 bits of one draw) and u ∈ [−1, 1) (its high 53 bits).
    #[inline(always)]
    fn ziggurat_draw(&mut self) -> (usize, f64) {
        let bits = self.next_u64();
        ((bits & 0x7f) as usize, 2.0 * ((bits >> 11) as f64 * (1.0 / (1u64 << 53) as f64)) - 1.0)
    }

    /// The 3 % of draws outside a layer's rectangle: the base layer's tail, or a wedge (accept x
    /// under the density between the layer's edges); a rejected draw starts over.
    #[cold]
    fn normal_slow(&mut self, mut i: usize, mut u: f64) -> f64 {
        loop {
            if i == 0 {
                return self.normal_tail(u < 0.0);
            }
            let x = u * ZIGGURAT_X[i];
            let f0 = (-0.5 * (ZIGGURAT_X[i] * ZIGGURAT_X[i] - x * x)).exp();
            let f1 = (-0.5 * (ZIGGURAT_X[i + 1] * ZIGGURAT_X[i + 1] - x * x)).exp();
            if f1 + self.uniform() * (f0 - f1) < 1.0 {
                return x;
            }
            (i, u) = self.ziggurat_draw();
            if u.abs() < ZIGGURAT_RATIO[i] {
                return u * ZIGGURAT_X[i];
            }
        }
    }

    /// A normal deviate beyond ±R (Marsaglia 1964).
    #[cold]
    fn normal_tail(&mut self, negative: bool) -> f64 {
        loop {
            // 1 − U ∈ (0, 1]: never ln 0
            let x = (1.0 - self.uniform()).ln() / ZIGGURAT_R;
            let y = (1.0 - self.uniform()).ln();
            if -2.0 * y >= x * x {
                return if negative { x - ZIGGURAT_R } else { ZIGGURAT_R - x };
            }
        }
    }
}

/// The ziggurat's rightmost layer edge R and the area V of each layer (Doornik 2005, 128 layers;
/// V enters through the table below, and the tests).
const ZIGGURAT_R: f64 = 3.442619855899;
#[cfg(test)]
const ZIGGURAT_V: f64 = 9.91256303526217e-3;
const ZIGGURAT_LAYERS: usize = 128;

/// Layer edges x_i: x_0 = V/f(R) (the base layer's width, tail included), x_1 = R,
/// x_i = √(−2·ln(V/x_{i−1} + f(x_{i−1}))) with f(x) = e^{−x²/2}, x_128 = 0. Written out (printed
/// once from that recurrence, which a test re-runs) so that no platform's `exp`/`ln` enters the
/// stream.
const ZIGGURAT_X: [f64; ZIGGURAT_LAYERS + 1] = [
    3.7130862467425505,
    3.442619855899,
    3.2230849845811416,
    3.0832288582168683,
    2.9786962526477803,
    2.894344007021529,
    2.8231253505489105,
    2.761169372387177,
    2.7061135731218195,
    2.6564064112613597,
    2.6109722484318474,
    2.569033625924938,
    2.5300096723888275,
    2.493454522095372,
    2.4590181774118305,
    2.42642064553375,
    2.3954342780110625,
    2.3658713701176386,
    2.3375752413392368,
    2.310413683698763,
    2.2842740596774718,
    2.2590595738691985,
    2.2346863955909795,
    2.2110814088787034,
    2.188180432076049,
    2.165926793748922,
    2.1442701823603953,
    2.1231657086739766,
    2.1025731351892385,
    2.082456237992017,
    2.0627822745083084,
    2.0435215366550676,
    2.0246469733773855,
    2.006133869963472,
    1.98795957412762,
    1.9701032608543265,
    1.9525457295535567,
    1.9352692282966228,
    1.9182573008645099,
    1.901494653105151,
    1.884967035707759,
    1.8686611409944887,
    1.8525645117280911,
    1.836665460258446,
    1.8209529965961255,
    1.8054167642192285,
    1.7900469825998586,
    1.7748343955860695,
    1.7597702248995934,
    1.7448461281138004,
    1.7300541605637305,
    1.7153867407136676,
    1.7008366185699169,
    1.6863968467791681,
    1.672060754097601,
    1.6578219209540241,
    1.6436741568628686,
    1.6296114794706347,
    1.615628095043161,
    1.6017183802213781,
    1.5878768648905761,
    1.5740982160230008,
    1.560377222366169,
    1.5467087798599104,
    1.5330878776740433,
    1.5195095847659401,
    1.5059690368632033,
    1.492461423781354,
    1.4789819769899242,
    1.4655259573427108,
    1.4520886428892246,
    1.4386653166845635,
    1.42525125451406,
    1.4118417124470577,
    1.3984319141310053,
    1.3850170377326518,
    1.3715922024273426,
    1.3581524543301435,
    1.344692751753547,
    1.3312079496656273,
    1.317692783209414,
    1.3041418501286168,
    1.2905495919261964,
    1.2769102735601556,
    1.263217961454621,
    1.2494664995730682,
    1.2356494832633627,
    1.2217602305399964,
    1.2077917504159497,
    1.1937367078331287,
    1.1795873846639882,
    1.1653356361647524,
    1.1509728421488674,
    1.1364898520131608,
    1.1218769225825422,
    1.107123647534036,
    1.0922188769072774,
    1.0771506248928957,
    1.0619059636948243,
    1.0464709007640454,
    1.0308302360681956,
    1.0149673952513305,
    0.9988642334929836,
    0.982500803515429,
    0.9658550794011499,
    0.9489026255113064,
    0.9316161966151508,
    0.9139652510230323,
    0.8959153525809377,
    0.8774274291129234,
    0.8584568431938132,
    0.8389522142975774,
    0.8188539067003573,
    0.7980920606440569,
    0.7765839878947599,
    0.7542306644540556,
    0.7309119106424888,
    0.7064796113354365,
    0.6807479186691546,
    0.6534786387399752,
    0.6243585973360507,
    0.5929629424714483,
    0.5586921784081852,
    0.5206560387620606,
    0.4774378372966898,
    0.4265479863554235,
    0.36287143109703196,
    0.27232086481396467,
    0.0,
];

/// x_{i+1}/x_i: below it a draw is inside layer i's rectangle.
const ZIGGURAT_RATIO: [f64; ZIGGURAT_LAYERS] = {
    let mut r = [0.0; ZIGGURAT_LAYERS];
    let mut i = 0;
    while i < ZIGGURAT_LAYERS {
        r[i] = ZIGGURAT_X[i + 1] / ZIGGURAT_X[i];
        i += 1;
    }
    r
};

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normal_has_unit_variance_and_zero_mean() {
        let mut r = Stream::new(42, Component::ImuNoise, 3);
        let n = 200_000;
        let (mut s, mut s2) = (0.0, 0.0);
        for _ in 0..n {
            let z = r.normal();
            s += z;
            s2 += z * z;
        }
        let mean = s / n as f64;
        let var = s2 / n as f64 - mean * mean;
        // Standard error of the mean is 1/sqrt(n) = 0.0022; of the variance sqrt(2/n) = 0.0032.
        assert!(mean.abs() < 0.01, "mean {mean}");
        assert!((var - 1.0).abs() < 0.015, "var {var}");
    }

    /// Φ(x) by Abramowitz & Stegun 7.1.26 (|error| < 1.5e-7, far below the KS bound below).
    fn normal_cdf(x: f64) -> f64 {
        let z = x.abs() / std::f64::consts::SQRT_2;
        let t = 1.0 / (1.0 + 0.3275911 * z);
        let poly = t * (0.254829592 + t * (-0.284496736 + t * (1.421413741 + t * (-1.453152027 + t * 1.061405429))));
        let erf = 1.0 - poly * (-z * z).exp();
        if x >= 0.0 { 0.5 * (1.0 + erf) } else { 0.5 * (1.0 - erf) }
    }

    /// The ziggurat's deviates follow Φ: Kolmogorov–Smirnov over 2,000,000 draws below the 1 %
    /// critical value 1.63/√n, and the tail beyond R (0.058 % of draws, the `normal_tail` path)
    /// and the wedges hold their share (a wedge test that accepts every draw fails that count).
    #[test]
    fn normal_deviates_are_normal_by_kolmogorov_smirnov_and_in_the_tails() {
        let mut r = Stream::new(11, Component::MocapNoise, 0);
        let n = 2_000_000;
        let mut z: Vec<f64> = (0..n).map(|_| r.normal()).collect();
        z.sort_by(f64::total_cmp);
        let d = z.iter().enumerate().map(|(i, x)| {
            let c = normal_cdf(*x);
            (c - i as f64 / n as f64).abs().max(((i + 1) as f64 / n as f64 - c).abs())
        });
        let d = d.fold(0.0, f64::max);
        assert!(d < 1.63 / (n as f64).sqrt(), "KS distance {d}");
        // beyond R = 3.4426: expected 2·(1 − Φ(R))·n = 1152, sd ≈ 34
        let tail = z.iter().filter(|x| x.abs() > ZIGGURAT_R).count() as f64;
        assert!((tail - 1152.0).abs() < 140.0, "{tail} draws beyond R");
        // beyond 2.5 (wedges and tail): 2·(1 − Φ(2.5))·n = 24839, sd ≈ 157
        let beyond = z.iter().filter(|x| x.abs() > 2.5).count() as f64;
        assert!((beyond - 24839.0).abs() < 630.0, "{beyond} draws beyond 2.5");
    }

    /// The written-out edges are the recurrence's (re-run here with this platform's libm), and
    /// the layers have equal areas V, the top one (up to x_128 = 0) included: R and V belong
    /// together.
    #[test]
    fn ziggurat_table_is_the_recurrence_with_equal_layer_areas() {
        let f = |x: f64| (-0.5 * x * x).exp();
        let mut x = [0.0; ZIGGURAT_LAYERS + 1];
        x[0] = ZIGGURAT_V / f(ZIGGURAT_R);
        x[1] = ZIGGURAT_R;
        for i in 2..ZIGGURAT_LAYERS {
            x[i] = (-2.0 * (ZIGGURAT_V / x[i - 1] + f(x[i - 1])).ln()).sqrt();
        }
        for i in 0..=ZIGGURAT_LAYERS {
            assert!((x[i] - ZIGGURAT_X[i]).abs() <= 1e-13 * x[i], "edge {i}: {} vs {}", x[i], ZIGGURAT_X[i]);
        }
        for i in 1..ZIGGURAT_LAYERS {
            let area = ZIGGURAT_X[i] * (f(ZIGGURAT_X[i + 1]) - f(ZIGGURAT_X[i]));
            assert!((area - ZIGGURAT_V).abs() < 1e-9, "layer {i}: {area}");
        }
    }

    #[test]
    fn streams_differ_by_vehicle_and_component() {
        let a = Stream::new(1, Component::MocapNoise, 0).next_u64();
        let b = Stream::new(1, Component::MocapNoise, 1).next_u64();
        let c = Stream::new(1, Component::LinkLoss, 0).next_u64();
        assert!(a != b && a != c && b != c);
    }
}
