//! Phase rotors `e^{+j2πt}` for back-projection, evaluated from a phase `t` in *cycles*.
//!
//! Back-projection multiplies every interpolated sample by `e^{+j2π r/λ}`; with `t = r/λ` in
//! cycles only the fractional part of `t` matters. Two evaluators live here, each with a stated
//! error that the tests below check:
//!
//! * [`rotor_f32`]: a branch-free polynomial (quadrant reduction, then odd degree-7 sine and
//!   even degree-8 cosine Taylor polynomials on \[−π/4, π/4\]). Truncation error ≤ 3.2·10⁻⁷
//!   (the first omitted terms, θ⁹/9! and θ¹⁰/10! at θ = π/4); with `f32` rounding the
//!   measured error against `libm` is below [`ROTOR_F32_MAX_ERR`] = 2·10⁻⁶ per component for
//!   `|t| ≤ 2¹⁶` cycles. It vectorises (no table, no branch), so it is the fast path's phase.
//! * [`rotor_q15`]: the fixed-point path's rotor, from [`SIN_Q15`], the crate's one quarter-wave
//!   sine table ([`QUARTER`] + 1 entries, [`PHASE_STEPS`] = 4·[`QUARTER`] = 8192 phase steps per
//!   cycle, also the Q15 FFT's twiddles through [`cos_sin_q15`]) built at compile time, so no
//!   `sin`/`cos` runs at run time. The phase is a 32-bit word ([`phase_word`]: the step in its
//!   high bits, [`PHASE_FRAC_BITS`] = 15 bits of fraction between steps below), and the rotor is
//!   interpolated linearly between the two neighbouring steps in integers (the idea of idsp's
//!   `cossin`). Error per component: each entry ≤ 0.5 LSB (and so is any convex combination of
//!   two), the chord's sag `(2π/8192)²/8·2¹⁵` = 0.0024 LSB, the rounding of the interpolation
//!   0.5 LSB, the phase word's resolution `2π·2⁻²⁸·2¹⁵` = 0.0008 LSB; ±1 saturates to ±32767
//!   (≤ 1 LSB where the exact value is within 0.5 of ±32768): ≤ 1.004 LSB, stated as
//!   [`ROTOR_Q15_MAX_ERR_LSB`] = 1.01 and checked against `libm` at every step and between steps.
//!   Measured: worst 1.0 LSB (13.0 reading the nearest step instead); on a carrier between steps
//!   the largest spur is 110 dB under it (78 dB with the nearest step), see the tests.
//!
//! Phases are unsigned fractions of a cycle: [`phase_word`] maps `t` (cycles, any sign) to a
//! phase word and [`phase_index`] to the nearest step in `0..PHASE_STEPS`, the only conversions
//! between the float geometry and the table.

use num_complex::Complex;

/// Entries per quarter wave of the Q15 sine table.
pub const QUARTER: usize = 2048;
/// Phase steps per cycle of [`rotor_q15`].
pub const PHASE_STEPS: u32 = 4 * QUARTER as u32;
/// Stated bound on the error of each component of [`rotor_f32`] against `libm`.
pub const ROTOR_F32_MAX_ERR: f32 = 2.0e-6;
/// Stated bound, in Q15 LSB, on the error of each component of [`rotor_q15`] and
/// [`rotor_q15_word`] against the exact `e^{j2πt}` for any `t` (module docs).
pub const ROTOR_Q15_MAX_ERR_LSB: f32 = 1.01;
/// Bits of a [`phase_word`] below one table step: the interpolation fraction of [`rotor_q15_word`].
pub const PHASE_FRAC_BITS: u32 = 15;

/// Stated bound, in Q15 LSB (`1.0 = 32768`), on the error of every entry of [`SIN_Q15`], hence of
/// both components of [`cos_sin_q15`] at every step, against the exact sine: rounding to nearest
/// (the measured worst entry is 0.4997 LSB; the Taylor series adds < 10⁻¹¹ LSB).
pub const SIN_Q15_MAX_ERR_LSB: f64 = 0.5;

/// The quarter-wave sine table: `SIN_Q15[k] = round(2¹⁵·sin(2πk/PHASE_STEPS))` for
/// `k = 0..=QUARTER`, in Q15 with `1.0 = 32768` (unsigned, so the peak is exact). Error
/// ≤ [`SIN_Q15_MAX_ERR_LSB`] per entry; 4 KiB. The one sine table of the crate: the back-projection
/// rotor and the Q15 FFT's twiddles read it through [`cos_sin_q15`].
pub static SIN_Q15: [u16; QUARTER + 1] = build_quarter_table();

/// Compile-time sine by Taylor series in `f64` (x in \[0, π/2\]; 14 terms, to x²⁷: truncation
/// < 10⁻²⁴, f64 rounding < 10⁻¹⁵).
const fn const_sin(x: f64) -> f64 {
    let x2 = x * x;
    let mut term = x;
    let mut sum = x;
    let mut n = 1u32;
    while n < 14 {
        let k = (2 * n) as f64;
        term = -term * x2 / (k * (k + 1.0));
        sum += term;
        n += 1;
    }
    sum
}

const fn build_quarter_table() -> [u16; QUARTER + 1] {
    let mut t = [0u16; QUARTER + 1];
    let mut k = 0;
    while k <= QUARTER {
        let x = core::f64::consts::FRAC_PI_2 * (k as f64) / (QUARTER as f64);
        // Round half up (v ≥ 0 here); the peak, 32768, fits a u16.
        t[k] = (const_sin(x) * 32768.0 + 0.5) as u16;
        k += 1;
    }
    t
}

/// `floor(x)` with float operations only, so loops calling it vectorise on baseline SSE2 (unlike
/// `libm::floorf` or an `as i32` round trip): `|x|` is rounded to an integer by adding and
/// subtracting 2²³ (exact for `|x| < 2²³`, where the sum's ulp is 1), the sign restored, and 1
/// taken off where that rounded up. `|x| ≥ 2²³` is already an integer and returned unchanged;
/// NaN stays NaN. Exact for every `f32` (tested against `libm::floorf`).
#[inline(always)]
pub fn floor_f32(x: f32) -> f32 {
    const TWO23: f32 = 8_388_608.0;
    let a = x.abs();
    let r = ((a + TWO23) - TWO23).copysign(x);
    let f = if r > x { r - 1.0 } else { r };
    if a < TWO23 {
        f
    } else {
        x
    }
}

/// The phase step in `0..PHASE_STEPS` nearest to `t` cycles (any sign; only `frac(t)` matters).
///
/// `t` must be finite; a non-finite `t` maps to step 0 (float-to-int `as` casts saturate).
#[inline(always)]
pub fn phase_index(t: f32) -> u32 {
    let f = t - floor_f32(t); // [0, 1]
    ((f * PHASE_STEPS as f32 + 0.5) as u32) & (PHASE_STEPS - 1)
}

/// `t` cycles (any sign; only `frac(t)` matters) as a phase word: `frac(t)·PHASE_STEPS·2¹⁵`,
/// the table step in bits 15..28 and the fraction between steps in bits 0..15 (of which `f32`
/// keeps at most its 24-bit mantissa's worth).
///
/// Float operations only, so loops calling it vectorise (a float-to-int `as` cast does not: its
/// saturation is done lane by lane): the step `k = floor(frac·2¹³)` and the fraction
/// `floor((frac·2¹³ − k)·2¹⁵)` are each exact (scalings by powers of two, a float minus its
/// floor) and read out of a mantissa ([`ROUND_MAGIC`]), which is `floor(frac·2²⁸)`, the
/// truncating cast's word, bit for bit (tested). `t` must be finite; a non-finite `t` gives some
/// word below `PHASE_STEPS·2¹⁵`.
#[inline(always)]
pub fn phase_word(t: f32) -> u32 {
    const ONE: u32 = PHASE_STEPS << PHASE_FRAC_BITS;
    let f = t - floor_f32(t); // [0, 1]
    let s = f * PHASE_STEPS as f32;
    let k = floor_small_f32(s); // [0, PHASE_STEPS]
    let g = floor_small_f32((s - k) * (1 << PHASE_FRAC_BITS) as f32); // [0, 2¹⁵)
    (((small_int(k) as u32) << PHASE_FRAC_BITS) | small_int(g) as u32) & (ONE - 1)
}

/// `e^{+j2π·w/(PHASE_STEPS·2¹⁵)}` as `i16` Q15 `(re, im)`, interpolated linearly in integers
/// between the table's two steps around phase word `w` ([`phase_word`]); ±1 saturated to ±32767.
/// Error ≤ [`ROTOR_Q15_MAX_ERR_LSB`] per component (module docs). Branch free.
#[inline(always)]
pub fn rotor_q15_word(w: u32) -> (i16, i16) {
    // Rounding the Q30 interpolation by 15 bits is `a + round((b − a)·f / 2¹⁵)`: `a·2¹⁵` is a
    // multiple of 2¹⁵.
    let (q, c, s) = quarter_q30(w);
    let q15 = |v: i32| ((v + (1 << (PHASE_FRAC_BITS - 1))) >> PHASE_FRAC_BITS).min(32767);
    let (x, y) = quarter_turns(q, q15(c), q15(s));
    (x as i16, y as i16)
}

/// Phase word `w`'s quarter turn and, within it, the cosine and sine interpolated linearly
/// between the table's two steps around it, unrounded: Q30 (entries ≤ 2¹⁵ shifted by
/// [`PHASE_FRAC_BITS`]: ≤ 2³⁰; neighbouring entries differ by ≤ 2¹⁵·2π/8192 < 26, so
/// `(b − a)·f < 26·2¹⁵`). The table has `QUARTER + 1` entries, so both steps exist.
#[inline(always)]
fn quarter_q30(w: u32) -> (u32, i32, i32) {
    const Q: usize = QUARTER;
    let k = (w >> PHASE_FRAC_BITS) & (PHASE_STEPS - 1);
    let f = (w & ((1 << PHASE_FRAC_BITS) - 1)) as i32;
    let q = k >> QUARTER.trailing_zeros();
    let r = k as usize & (Q - 1);
    let lerp = |a: u16, b: u16| ((a as i32) << PHASE_FRAC_BITS) + (b as i32 - a as i32) * f;
    (
        q,
        lerp(SIN_Q15[Q - r], SIN_Q15[Q - r - 1]),
        lerp(SIN_Q15[r], SIN_Q15[r + 1]),
    )
}

/// [`rotor_q15_word`] without its last rounding: the interpolation between the table's two steps
/// kept to [`PHASE_FRAC_BITS`] more bits, as `i32` Q30 `(re, im)` with `1.0 = 2³⁰`. Error
/// ≤ [`ROTOR_Q30_MAX_ERR_LSB`] Q15 LSB per component (the entries' rounding and the chord's
/// sag), and **continuous in the phase**: it has no steps of an LSB where the rounding flips,
/// which an estimator that compares rotated sums a hair apart in phase would see as ripple
/// ([`crate::direct_path`]). Branch free.
#[inline(always)]
pub fn rotor_q30_word(w: u32) -> (i32, i32) {
    let (q, c, s) = quarter_q30(w);
    quarter_turns(q, c, s)
}

/// Stated bound, in Q15 LSB, on the error of each component of [`rotor_q30_word`] against the
/// exact `e^{j2πt}`: the entries' [`SIN_Q15_MAX_ERR_LSB`] (a convex combination of two entries
/// errs no more than they do) plus the chord's sag `(2π/8192)²/8·2¹⁵` = 0.0024 LSB.
pub const ROTOR_Q30_MAX_ERR_LSB: f64 = 0.503;

/// `(cos, sin)` of `2πk/PHASE_STEPS` in Q15 with `1.0 = 32768` (values in \[−32768, 32768\]),
/// each within [`SIN_Q15_MAX_ERR_LSB`] of exact; `k` is taken modulo [`PHASE_STEPS`]. Branch free.
#[inline(always)]
pub fn cos_sin_q15(k: u32) -> (i32, i32) {
    quadrant_cos_sin::<false>(k)
}

/// `e^{+j2π k/PHASE_STEPS}` as `i16` Q15 `(re, im)`: [`cos_sin_q15`] with ±1 saturated to ±32767
/// (so negating a component cannot overflow). `k` is taken modulo [`PHASE_STEPS`]. Branch free.
#[inline(always)]
pub fn rotor_q15_index(k: u32) -> (i16, i16) {
    let (c, s) = quadrant_cos_sin::<true>(k);
    (c as i16, s as i16)
}

/// `(cos, sin)` of `2πk/PHASE_STEPS` from [`SIN_Q15`] by quadrant symmetry: with
/// `k = q·QUARTER + r`, `r < QUARTER`, `(cos r, sin r) = (SIN_Q15[QUARTER − r], SIN_Q15[r])` is
/// rotated by `q` quarter turns (selects only). `SAT` saturates entries of 32768 to 32767.
#[inline(always)]
fn quadrant_cos_sin<const SAT: bool>(k: u32) -> (i32, i32) {
    const Q: usize = QUARTER;
    let k = k & (PHASE_STEPS - 1);
    let q = k >> QUARTER.trailing_zeros();
    let r = k as usize & (Q - 1);
    let (s, c) = (SIN_Q15[r] as i32, SIN_Q15[Q - r] as i32);
    // The last eight entries, the peak included, round to 32768.
    let (s, c) = if SAT {
        (s.min(32767), c.min(32767))
    } else {
        (s, c)
    };
    quarter_turns(q, c, s)
}

/// `(c, s)` rotated by `q` quarter turns (`q` in 0..4): 0 (c, s), 1 (−s, c), 2 (−c, −s),
/// 3 (s, −c). Selects only.
#[inline(always)]
fn quarter_turns(q: u32, c: i32, s: i32) -> (i32, i32) {
    let (x, y) = if q & 1 == 1 { (s, c) } else { (c, s) };
    let x = if (q ^ (q >> 1)) & 1 == 1 { -x } else { x };
    let y = if q >= 2 { -y } else { y };
    (x, y)
}

/// `e^{+j2πt}` in Q15 (see the module docs for the error bound).
#[inline(always)]
pub fn rotor_q15(t: f32) -> (i16, i16) {
    rotor_q15_word(phase_word(t))
}

/// `1.5·2²³`: a float `x` with `|x| < 2²²` added to it lands in \[2²³, 2²⁴), where the ulp is
/// 1, so the sum is `x` rounded to the nearest integer (ties to even) plus `ROUND_MAGIC`, and its
/// mantissa's low bits are that integer (`ROUND_MAGIC`'s own mantissa, 2²², is ≡ 0 mod 4).
pub const ROUND_MAGIC: f32 = 12_582_912.0;

/// The integer `v` (`|v| < 2²²`, already integral) as `i32`, read out of the mantissa of
/// `v + ROUND_MAGIC` (which is `v + 2²²`): integer-bit operations that vectorise, unlike a
/// float-to-int `as` cast, whose saturation is done lane by lane.
#[inline(always)]
pub fn small_int(v: f32) -> i32 {
    ((v + ROUND_MAGIC).to_bits() & 0x7F_FFFF) as i32 - (1 << 22)
}

/// `floor(x)` exact for `|x| < 2²²` in four float operations (round to nearest through
/// [`ROUND_MAGIC`], then 1 off where that rounded up), vectorising on any target; for larger
/// `|x|` a finite value within 2 of `x` (`x` itself beyond 2²⁴). For indices that are clamped
/// into a much shorter range anyway; [`floor_f32`] is exact everywhere.
#[inline(always)]
pub fn floor_small_f32(x: f32) -> f32 {
    let r = (x + ROUND_MAGIC) - ROUND_MAGIC;
    if r > x {
        r - 1.0
    } else {
        r
    }
}

/// `e^{+j2πt}` in `f32` by quadrant reduction and polynomials (error ≤ [`ROTOR_F32_MAX_ERR`] per
/// component for `|t| ≤ 2¹⁶`; larger `|t|` lose fractional bits in `t` itself, and beyond
/// `|t| ≥ 2²⁰` the result is a unit quarter turn, meaningless but finite).
#[inline(always)]
pub fn rotor_f32(t: f32) -> Complex<f32> {
    // Nearest quarter turn: 4t = q4 + 4u, |u| ≤ 1/8 cycle, q4 rounded through ROUND_MAGIC;
    // q4 mod 4 is in the sum's low mantissa bits (exact for |4t| < 2²²).
    let x = 4.0 * t;
    let m = x + ROUND_MAGIC;
    let q4 = m - ROUND_MAGIC;
    let u = if x.abs() < 4_194_304.0 {
        t - 0.25 * q4
    } else {
        0.0
    };
    let th = core::f32::consts::TAU * u;
    let th2 = th * th;
    let s = th * (1.0 + th2 * (-1.0 / 6.0 + th2 * (1.0 / 120.0 + th2 * (-1.0 / 5040.0))));
    let c = 1.0 + th2 * (-0.5 + th2 * (1.0 / 24.0 + th2 * (-1.0 / 720.0 + th2 * (1.0 / 40320.0))));
    // Rotate by q = q4 mod 4 quarter turns: odd q swaps (c, s) → (−s, c); q ≥ 2 negates both,
    // a sign flip by xor (integer operations on the bits, vectorise).
    let q = m.to_bits() & 3;
    let (re, im) = if q & 1 != 0 { (-s, c) } else { (c, s) };
    let flip = (q & 2) << 30;
    Complex::new(
        f32::from_bits(re.to_bits() ^ flip),
        f32::from_bits(im.to_bits() ^ flip),
    )
}

/// `e^{+j2πt}` in `f32` from `libm::sincosf` after reducing `t` to `[−½, ½)`: the exact path.
#[inline]
pub fn rotor_f32_libm(t: f32) -> Complex<f32> {
    let f = t - libm::floorf(t + 0.5);
    let (s, c) = libm::sincosf(core::f32::consts::TAU * f);
    Complex::new(c, s)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn exact(t: f64) -> (f64, f64) {
        let f = t - libm::floor(t);
        let a = core::f64::consts::TAU * f;
        (libm::cos(a), libm::sin(a))
    }

    #[test]
    fn cos_sin_q15_is_within_the_stated_lsb_of_exact_at_every_step() {
        let mut worst = 0.0f64;
        for k in 0..PHASE_STEPS {
            let (c, s) = cos_sin_q15(k);
            // The rotor is the same table saturated to i16 (±1 → ±32767).
            let sat = |v: i32| v.clamp(-32767, 32767) as i16;
            assert_eq!(rotor_q15_index(k), (sat(c), sat(s)), "k = {k}");
            let (ec, es) = exact(k as f64 / PHASE_STEPS as f64);
            worst = worst
                .max((c as f64 - ec * 32768.0).abs())
                .max((s as f64 - es * 32768.0).abs());
        }
        assert!(worst <= SIN_Q15_MAX_ERR_LSB, "worst {worst} LSB");
        // The doc's measured worst entry, to its four digits.
        assert!((worst - 0.4997).abs() < 5e-5, "worst {worst} LSB");
        // The axes are exact, 45° correctly rounded; k wraps.
        assert_eq!(SIN_Q15[0], 0);
        assert_eq!(SIN_Q15[QUARTER], 32768);
        assert_eq!(SIN_Q15[QUARTER / 2], 23170); // 2¹⁵/√2 = 23170.475
        let q = QUARTER as u32;
        assert_eq!(cos_sin_q15(0), (32768, 0));
        assert_eq!(cos_sin_q15(q), (0, 32768));
        assert_eq!(cos_sin_q15(2 * q), (-32768, 0));
        assert_eq!(cos_sin_q15(3 * q), (0, -32768));
        assert_eq!(cos_sin_q15(PHASE_STEPS + 5), cos_sin_q15(5));
        assert_eq!(rotor_q15_index(2 * q), (-32767, 0));
    }

    #[test]
    fn rotor_q15_error_is_within_stated_lsb_for_every_step_and_between_steps() {
        let (mut worst, mut worst_nearest) = (0.0f64, 0.0f64);
        // Every step, and points a third and a half step off it (the half step is the worst
        // case of phase rounding and of the chord's sag).
        for k in 0..PHASE_STEPS {
            for off in [0.0, 0.33, 0.499] {
                let t = (k as f64 + off) / PHASE_STEPS as f64;
                let (c, s) = exact(t);
                let err = |(re, im): (i16, i16)| {
                    (re as f64 - c * 32768.0)
                        .abs()
                        .max((im as f64 - s * 32768.0).abs())
                };
                worst = worst.max(err(rotor_q15(t as f32)));
                worst_nearest = worst_nearest.max(err(rotor_q15_index(phase_index(t as f32))));
            }
        }
        assert!(worst <= ROTOR_Q15_MAX_ERR_LSB as f64, "worst {worst} LSB");
        // Interpolation is the gain: the nearest step alone is off by ~12.6 LSB half a step away.
        assert!(
            worst_nearest > 12.0,
            "nearest step: worst {worst_nearest} LSB"
        );
    }

    #[test]
    fn rotor_q30_is_within_its_bound_and_continuous_across_steps() {
        let mut worst = 0.0f64;
        for k in 0..PHASE_STEPS {
            for off in [0.0, 0.33, 0.499, 0.999] {
                let t = (k as f64 + off) / PHASE_STEPS as f64;
                let w = (t * (1u64 << 28) as f64) as u32;
                let (c, s) = exact(w as f64 / (1u64 << 28) as f64);
                let (re, im) = rotor_q30_word(w);
                let lsb = (1u32 << 15) as f64;
                worst = worst
                    .max((re as f64 / lsb - c * 32768.0).abs())
                    .max((im as f64 / lsb - s * 32768.0).abs());
            }
        }
        assert!(worst <= ROTOR_Q30_MAX_ERR_LSB, "worst {worst} LSB");
        // Continuity: one phase word apart the components move by |b − a| ≤ 26 Q30 units
        // (neighbouring entries differ by < 26 Q15 LSB), across a step boundary as inside one.
        for k in 1..PHASE_STEPS {
            let w = k << PHASE_FRAC_BITS;
            let (a, b) = (rotor_q30_word(w - 1), rotor_q30_word(w));
            assert!(
                (a.0 - b.0).abs() <= 26 && (a.1 - b.1).abs() <= 26,
                "{k}: {a:?} {b:?}"
            );
        }
    }

    /// The largest spur of a rotor sequence, dB below its carrier: `e^{j2π m n/N}` for
    /// `n = 0..N` (a carrier on DFT bin `m`, phases between the table's steps), its `N`-point DFT
    /// by direct sums in `f64`, the strongest other bin against bin `m`.
    fn worst_spur_dbc(rotor: impl Fn(f32) -> (i16, i16)) -> f64 {
        const N: usize = 1000;
        const M: usize = 37;
        let x: Vec<(f64, f64)> = (0..N)
            .map(|n| {
                let (re, im) = rotor(((n * M) % N) as f32 / N as f32);
                (re as f64, im as f64)
            })
            .collect();
        let power = |k: usize| {
            let (mut re, mut im) = (0.0, 0.0);
            for (n, &(a, b)) in x.iter().enumerate() {
                let ph = -core::f64::consts::TAU * ((k * n) % N) as f64 / N as f64;
                let (c, s) = (libm::cos(ph), libm::sin(ph));
                re += a * c - b * s;
                im += a * s + b * c;
            }
            re * re + im * im
        };
        let carrier = power(M);
        let spur = (0..N).filter(|&k| k != M).map(power).fold(0.0, f64::max);
        10.0 * libm::log10(carrier / spur.max(1e-300))
    }

    #[test]
    fn interpolated_rotor_spurs_are_far_below_those_of_the_nearest_step() {
        let interp = worst_spur_dbc(rotor_q15);
        let nearest = worst_spur_dbc(|t| rotor_q15_index(phase_index(t)));
        // Measured: 109.6 dBc interpolated, 78.3 dBc with the nearest step.
        assert!(
            interp > 90.0,
            "interpolated rotor: worst spur {interp:.1} dBc"
        );
        assert!(
            interp > nearest + 20.0,
            "{interp:.1} vs nearest {nearest:.1} dBc"
        );
    }

    #[test]
    fn phase_word_holds_the_step_above_the_fraction() {
        assert_eq!(phase_word(0.0), 0);
        // The word is the truncating cast of frac(t)·2²⁸, bit for bit.
        let mut t = -3000.0f32;
        while t < 3000.0 {
            let f = t - libm::floorf(t);
            let want = ((f as f64 * (PHASE_STEPS << PHASE_FRAC_BITS) as f64) as u32)
                & ((PHASE_STEPS << PHASE_FRAC_BITS) - 1);
            assert_eq!(phase_word(t), want, "t = {t}");
            t += 0.013_7 * (1.0 + libm::fabsf(t) * 1e-3);
        }
        for t in [
            1.0f32 - f32::EPSILON / 2.0,
            -f32::EPSILON / 4.0,
            1e-30,
            2e6 + 0.5,
        ] {
            let f = t - libm::floorf(t);
            let want = ((f as f64 * (PHASE_STEPS << PHASE_FRAC_BITS) as f64) as u32)
                & ((PHASE_STEPS << PHASE_FRAC_BITS) - 1);
            assert_eq!(phase_word(t), want, "t = {t}");
        }
        assert_eq!(phase_word(0.25), (QUARTER as u32) << PHASE_FRAC_BITS);
        assert_eq!(phase_word(-0.25), (3 * QUARTER as u32) << PHASE_FRAC_BITS);
        assert_eq!(phase_word(1000.5) >> PHASE_FRAC_BITS, 2 * QUARTER as u32);
        // Half a step past step 3: the fraction is half of 2¹⁵.
        let w = phase_word(3.5 / PHASE_STEPS as f32);
        assert_eq!((w >> PHASE_FRAC_BITS, w & 0x7FFF), (3, 1 << 14));
        assert_eq!(
            rotor_q15_word((QUARTER as u32) << PHASE_FRAC_BITS),
            (0, 32767)
        );
    }

    #[test]
    fn rotor_f32_matches_libm_within_stated_error() {
        let mut worst = 0.0f32;
        let mut t = -70000.0f32;
        // Non-uniform stride so every quadrant and fraction is visited.
        while t < 70000.0 {
            let z = rotor_f32(t);
            let e = rotor_f32_libm(t);
            worst = worst.max((z.re - e.re).abs()).max((z.im - e.im).abs());
            t += 0.618_034 * (1.0 + libm::fabsf(t) * 1e-4);
        }
        for k in 0..10_000 {
            let t = k as f32 * 1.37e-4 - 0.5;
            let z = rotor_f32(t);
            let (c, s) = exact(t as f64);
            worst = worst
                .max((z.re - c as f32).abs())
                .max((z.im - s as f32).abs());
        }
        assert!(worst <= ROTOR_F32_MAX_ERR, "worst {worst}");
    }

    #[test]
    fn floor_small_f32_is_exact_below_two_to_the_22_and_within_two_above() {
        let mut x = -4_194_303.9f32;
        while x < 4_194_304.0 {
            assert_eq!(floor_small_f32(x), libm::floorf(x), "x = {x}");
            for y in [
                x.next_up(),
                x.next_down(),
                libm::floorf(x),
                libm::floorf(x) + 0.5,
            ] {
                if y.abs() < 4_194_304.0 {
                    assert_eq!(floor_small_f32(y), libm::floorf(y), "y = {y}");
                }
            }
            x += 0.731 * (1.0 + x.abs() * 1e-3);
        }
        for x in [
            4.2e6f32,
            -4.2e6,
            8.4e6,
            -8.4e6,
            1.6e7,
            3e9,
            -3e9,
            1e30,
            -1e30,
            f32::MAX / 16.0,
        ] {
            let f = floor_small_f32(x);
            assert!(f.is_finite() && (f - x).abs() <= 2.0, "x = {x}: {f}");
        }
    }

    #[test]
    fn rotor_f32_is_a_finite_unit_quarter_turn_beyond_its_range() {
        for t in [1.1e6f32, -1.1e6, 3e9, 1e30, -1e30, f32::MAX / 16.0] {
            let z = rotor_f32(t);
            assert!(z.re.is_finite() && z.im.is_finite(), "t = {t}");
            assert!((z.norm() - 1.0).abs() < 1e-6, "t = {t}: {z}");
        }
    }

    #[test]
    fn floor_f32_matches_libm_floor() {
        for x in [
            -3.5f32,
            -3.0,
            -0.0,
            0.0,
            0.3,
            2.999_999_8,
            -2.000_000_2,
            1e7,
            -1e7,
            3e9,
            -3e9,
            1e30,
        ] {
            assert_eq!(floor_f32(x), libm::floorf(x), "x = {x}");
        }
        assert!(floor_f32(f32::NAN).is_nan());
    }

    #[test]
    fn phase_index_wraps_negative_and_large_phases() {
        assert_eq!(phase_index(0.0), 0);
        assert_eq!(phase_index(0.25), QUARTER as u32);
        assert_eq!(phase_index(-0.25), 3 * QUARTER as u32);
        assert_eq!(phase_index(1000.5), 2 * QUARTER as u32);
        assert_eq!(phase_index(0.99999), 0);
        assert_eq!(rotor_q15_index(QUARTER as u32), (0, 32767));
    }
}
