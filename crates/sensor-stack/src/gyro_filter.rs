//! The rate loop's gyro: body rates (FRD, rad/s in Q16) through two
//! fixed-point sections per axis, a low-pass and a static notch, each
//! configurable and each possibly off. The AHRS integrates the unfiltered
//! gyro (its attitude gains nothing from the delay); the rate loop, whose
//! D term amplifies what the frame's vibration aliases into a 1 kHz gyro,
//! gets the filtered one ([`Pipeline::body_rates_q16`](crate::pipeline::Pipeline::body_rates_q16)).
//!
//! The design ([`GyroFilterConfig::design`]) is a `const fn`: a setting
//! fixed at build time is designed by the compiler, and the board carries
//! only the Q29 (biquad) and Q30 (PT1) taps and the per-sample code.
//!
//! ```
//! use sensor_stack::gyro_filter::{GyroFilter, GyroFilterConfig, GyroLowPass, GyroNotch};
//! const CFG: GyroFilterConfig = GyroFilterConfig {
//!     low_pass: GyroLowPass::Pt1 { cutoff_hz: 100.0 },
//!     notch: Some(GyroNotch { center_hz: 180.0, q: 2.0 }),
//! };
//! let d = CFG.design(1000.0).unwrap();
//! // What it costs the rate loop at 50 Hz: 1.5 ms of group delay (PT1
//! // 1.0 ms, notch 0.5 ms), 32° of phase.
//! let r = d.response(50.0);
//! # if r.group_delay_s == 0.0 { return; } // built with `no-gyro-filter`
//! assert!((r.group_delay_s - 0.00147).abs() < 0.00005);
//! assert!((r.phase_rad.to_degrees() + 32.1).abs() < 0.5);
//! let mut f = GyroFilter::new(&d);
//! let held = [1 << 16, -(2 << 16), 0]; // 1, −2, 0 rad/s
//! let mut out = [0; 3];
//! for _ in 0..500 {
//!     out = f.apply(held);
//! }
//! assert_eq!(out, held);
//! ```

use core::f32::consts::FRAC_1_SQRT_2;
use filters::{BiquadCoeffs, BiquadQ, FilterError, Pt1, Pt1Q, Response};

/// The gyro low-pass.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum GyroLowPass {
    /// None.
    Off,
    /// First order (Betaflight's PT1), cut-off in Hz: delay ≈ 1/(2π·f_c)
    /// at low frequency, −20 dB/decade.
    Pt1 {
        /// −3 dB frequency, Hz.
        cutoff_hz: f32,
    },
    /// Second-order Butterworth, cut-off in Hz: delay ≈ √2/(2π·f_c) at low
    /// frequency, −40 dB/decade.
    Biquad {
        /// −3 dB frequency, Hz.
        cutoff_hz: f32,
    },
}

/// A static notch: centre (Hz) and quality factor (the −3 dB width is
/// centre/Q).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct GyroNotch {
    /// Centre frequency, Hz.
    pub center_hz: f32,
    /// Quality factor.
    pub q: f32,
}

/// What the rate loop's gyro goes through.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct GyroFilterConfig {
    /// The low-pass.
    pub low_pass: GyroLowPass,
    /// The notch, if any.
    pub notch: Option<GyroNotch>,
}

impl GyroFilterConfig {
    /// No filtering: the rate loop gets the gyro as read.
    pub const OFF: Self = Self {
        low_pass: GyroLowPass::Off,
        notch: None,
    };

    /// The sections for a gyro sampled at `sample_hz`.
    ///
    /// # Errors
    /// [`FilterError`] for a frequency not within (0, 0.45·`sample_hz`), a
    /// quality factor not within (0.1, 50], or a bad sample rate.
    pub const fn design(&self, sample_hz: f32) -> Result<GyroFilterDesign, FilterError> {
        let low = match self.low_pass {
            GyroLowPass::Off => Ok(Section::Off),
            GyroLowPass::Pt1 { cutoff_hz } => match Pt1::new(cutoff_hz, sample_hz) {
                Ok(p) => Ok(Section::pt1(&p)),
                Err(e) => Err(e),
            },
            GyroLowPass::Biquad { cutoff_hz } => {
                Section::biquad(BiquadCoeffs::low_pass(cutoff_hz, FRAC_1_SQRT_2, sample_hz))
            }
        };
        // Off, the notch is the identity section (b₀ = 1): the board's
        // filter has one, and one code path is cheaper than a branch.
        let notch = match self.notch {
            None => Ok(BiquadCoeffs::PASS),
            Some(n) => BiquadCoeffs::notch(n.center_hz, n.q, sample_hz),
        };
        match (low, notch) {
            (Ok(low), Ok(notch)) => Ok(GyroFilterDesign::of(low, BiquadQ::new(&notch), sample_hz)),
            (Err(e), _) | (_, Err(e)) => Err(e),
        }
    }
}

/// The low-pass stage in fixed point: off, a PT1 (one multiply a sample)
/// or a biquad section (five).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "no-gyro-filter", allow(dead_code))]
enum Section {
    Off,
    Pt1(Pt1Q),
    Biquad(BiquadQ),
}

// With `no-gyro-filter` the design drops its sections unused.
#[cfg_attr(feature = "no-gyro-filter", allow(dead_code))]
impl Section {
    /// The fixed-point PT1 of `p`.
    const fn pt1(p: &Pt1) -> Self {
        Self::Pt1(Pt1Q::new(p))
    }

    /// The fixed-point section of a design, or its error.
    const fn biquad(c: Result<BiquadCoeffs, FilterError>) -> Result<Self, FilterError> {
        match c {
            Ok(c) => Ok(Self::Biquad(BiquadQ::new(&c))),
            Err(e) => Err(e),
        }
    }

    /// One sample.
    #[inline(always)]
    fn apply(&mut self, x: i32) -> i32 {
        match self {
            Self::Off => x,
            Self::Pt1(p) => p.apply(x),
            Self::Biquad(b) => b.apply(x),
        }
    }

    /// Gain, phase and delay at `f_hz` for `sample_hz`.
    fn response(&self, f_hz: f32, sample_hz: f32) -> Response {
        match self {
            Self::Off => Response {
                gain: 1.0,
                phase_rad: 0.0,
                group_delay_s: 0.0,
            },
            Self::Pt1(p) => p.response(f_hz, sample_hz),
            Self::Biquad(b) => b.response(f_hz, sample_hz),
        }
    }
}

/// The designed sections at a sample rate, in their fixed-point form (made
/// in the `const fn` too, so a build-time design leaves no conversion code
/// on the board).
/// With the `no-gyro-filter` feature it holds nothing (the rate loop gets
/// the gyro as read): no taps in the calibration build's flash.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GyroFilterDesign {
    #[cfg(not(feature = "no-gyro-filter"))]
    sections: (Section, BiquadQ),
    #[cfg(not(feature = "no-gyro-filter"))]
    sample_hz: f32,
}

impl GyroFilterDesign {
    /// Both sections off.
    pub const PASS: Self = Self::of(Section::Off, BiquadQ::new(&BiquadCoeffs::PASS), 1000.0);

    /// The sections `low` then `notch` at `sample_hz`.
    #[allow(unused_variables)] // all of them with `no-gyro-filter`
    const fn of(low: Section, notch: BiquadQ, sample_hz: f32) -> Self {
        Self {
            #[cfg(not(feature = "no-gyro-filter"))]
            sections: (low, notch),
            #[cfg(not(feature = "no-gyro-filter"))]
            sample_hz,
        }
    }

    /// Gain, phase and delay of the two sections together at `f_hz` (of
    /// the Q29 taps as they run; unity with `no-gyro-filter`).
    #[must_use]
    #[allow(unused_variables)] // `f_hz` with `no-gyro-filter`
    pub fn response(&self, f_hz: f32) -> Response {
        #[cfg(not(feature = "no-gyro-filter"))]
        {
            let a = self.sections.0.response(f_hz, self.sample_hz);
            let b = self.sections.1.response(f_hz, self.sample_hz);
            Response {
                gain: a.gain * b.gain,
                phase_rad: a.phase_rad + b.phase_rad,
                group_delay_s: a.group_delay_s + b.group_delay_s,
            }
        }
        #[cfg(feature = "no-gyro-filter")]
        Response {
            gain: 1.0,
            phase_rad: 0.0,
            group_delay_s: 0.0,
        }
    }
}

/// The filter state: two sections on each of three axes (none with the
/// `no-gyro-filter` feature).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct GyroFilter {
    #[cfg(not(feature = "no-gyro-filter"))]
    axes: [(Section, BiquadQ); 3],
}

impl GyroFilter {
    /// The fixed-point sections of `d`, at rest.
    #[must_use]
    #[cfg(not(feature = "no-gyro-filter"))]
    pub const fn new(d: &GyroFilterDesign) -> Self {
        Self {
            axes: [d.sections; 3],
        }
    }

    /// With the `no-gyro-filter` feature: no state.
    #[cfg(feature = "no-gyro-filter")]
    pub const fn new(_: &GyroFilterDesign) -> Self {
        Self {}
    }

    /// One sample of body rates (any Q-format; the pipeline's is Q16
    /// rad/s): the filtered rates. The sections start from rest (all zero):
    /// the pipeline runs them from the boot, while the craft stands still,
    /// so the start's transient is over long before an arming.
    // Not inlined: one loop over the three axes, not three copies of it in
    // the sample task.
    #[cfg(not(feature = "no-gyro-filter"))]
    #[inline(never)]
    pub fn apply(&mut self, rates: [i32; 3]) -> [i32; 3] {
        let mut out = rates;
        for ((low, notch), x) in self.axes.iter_mut().zip(out.iter_mut()) {
            *x = notch.apply(low.apply(*x));
        }
        out
    }

    /// With the `no-gyro-filter` feature: the rates unchanged.
    #[cfg(feature = "no-gyro-filter")]
    #[inline(always)]
    pub fn apply(&mut self, rates: [i32; 3]) -> [i32; 3] {
        rates
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const FS: f32 = 1000.0;

    #[test]
    fn off_passes_the_gyro_unchanged() {
        let mut f = GyroFilter::new(&GyroFilterConfig::OFF.design(FS).unwrap());
        for r in [[1, -2, 3], [i32::MAX, i32::MIN, 0], [65_536, -65_536, 7]] {
            assert_eq!(f.apply(r), r);
        }
        assert_eq!(
            GyroFilterConfig::OFF.design(FS).unwrap(),
            GyroFilterDesign::PASS
        );
    }

    #[test]
    #[cfg(not(feature = "no-gyro-filter"))]
    fn each_axis_is_filtered_on_its_own() {
        let cfg = GyroFilterConfig {
            low_pass: GyroLowPass::Biquad { cutoff_hz: 80.0 },
            notch: None,
        };
        let mut f = GyroFilter::new(&cfg.design(FS).unwrap());
        f.apply([0; 3]);
        // A step on roll only: pitch and yaw stay 0, roll rises smoothly.
        let first = f.apply([1 << 16, 0, 0]);
        assert!(first[0] > 0 && first[0] < 1 << 14, "{first:?}");
        assert_eq!(&first[1..], &[0, 0]);
    }

    #[test]
    #[cfg(not(feature = "no-gyro-filter"))]
    fn the_notch_removes_its_centre_on_the_q16_gyro() {
        let cfg = GyroFilterConfig {
            low_pass: GyroLowPass::Off,
            notch: Some(GyroNotch {
                center_hz: 200.0,
                q: 3.0,
            }),
        };
        let mut f = GyroFilter::new(&cfg.design(FS).unwrap());
        let mut peak = 0;
        for i in 0..2000 {
            let x =
                (libm::sinf(2.0 * core::f32::consts::PI * 200.0 * i as f32 / FS) * 65536.0) as i32;
            let y = f.apply([x, 0, -x]);
            if i > 1000 {
                peak = peak.max(y[0].abs()).max(y[2].abs());
            }
        }
        // 1 rad/s at the centre comes out below 1 % of it.
        assert!(peak < 655, "{peak}");
    }

    #[test]
    #[cfg(feature = "no-gyro-filter")]
    fn without_the_feature_the_gyro_passes_unchanged() {
        let cfg = GyroFilterConfig {
            low_pass: GyroLowPass::Biquad { cutoff_hz: 80.0 },
            notch: None,
        };
        let d = cfg.design(FS).unwrap();
        let mut f = GyroFilter::new(&d);
        assert_eq!(f.apply([0; 3]), [0; 3]);
        assert_eq!(f.apply([1 << 16, -5, 7]), [1 << 16, -5, 7]);
        assert_eq!(d.response(100.0).gain, 1.0);
    }

    #[test]
    fn designs_out_of_range_are_refused() {
        let bad = GyroFilterConfig {
            low_pass: GyroLowPass::Pt1 { cutoff_hz: 600.0 },
            notch: None,
        };
        assert_eq!(bad.design(FS), Err(FilterError::Frequency));
        let bad_q = GyroFilterConfig {
            low_pass: GyroLowPass::Off,
            notch: Some(GyroNotch {
                center_hz: 150.0,
                q: 0.0,
            }),
        };
        assert_eq!(bad_q.design(FS), Err(FilterError::Quality));
    }
}
