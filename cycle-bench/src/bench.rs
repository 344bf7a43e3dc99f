//! The benchmark state and its C ABI (see the crate documentation).

use core::cell::UnsafeCell;

use ekf_core::{
    complementary::ComplementaryParams, AttitudeFilter, Complementary, Ekf, Euler, Flags, GyroOnly,
    ImuSample, Settings, SsUkf, Ukf, Vec3,
};

include!(concat!(env!("OUT_DIR"), "/trace.rs"));

/// Filter ids of `ahrs_bench_select`, in order, as the tools name them. `ekf-moving` is the
/// EKF on the `MOVING` lap (a hand's shaking: the tilt low-pass in use), the others run on the
/// gentle motion part of `TRACE` (which the EKF takes raw).
pub const FILTERS: [&str; 6] = ["ekf", "ukf", "ssukf", "cf", "gyro", "ekf-moving"];

/// `ahrs_bench_select`: unknown filter id.
pub const BAD_ID: u32 = 1;
/// `ahrs_bench_select`: the filter was still initialising after the trace's still part.
pub const NOT_INITIALISED: u32 = 2;
/// `ahrs_bench_step*`: no filter (or another filter) is selected.
pub const NOT_SELECTED: u32 = 0xFFFF_FFFF;
/// The accelerometer-used bit of the returned flags.
pub const ACCEL_USED: u32 = Flags::ACCEL_USED.0 as u32;

/// The selected filter. One static slot sized for the largest (no heap on the target).
#[allow(clippy::large_enum_variant)]
enum Active {
    None,
    Ekf(Ekf),
    Ukf(Ukf),
    SsUkf(SsUkf),
    Cf(Complementary),
    Gyro(GyroOnly),
}

struct State {
    active: Active,
    /// Next motion sample, `0..MOTION_LEN`.
    cursor: usize,
    /// The motion samples come from `MOVING`, not from `TRACE`'s motion part.
    moving: bool,
    /// FNV-1a digest of every step's full state so far ([`ahrs_bench_digest`]).
    digest: u32,
}

/// Single-threaded global: the bench runs on one core with no interrupts touching it.
pub struct Global<T>(UnsafeCell<T>);
// SAFETY: only the exported functions touch it, and they are never called concurrently (one
// core, called from the thread mode of a bare-metal program or from one host thread).
unsafe impl<T> Sync for Global<T> {}

static STATE: Global<State> = Global(UnsafeCell::new(State {
    active: Active::None,
    cursor: 0,
    moving: false,
    digest: FNV_OFFSET,
}));

/// The soft-float routines linked (`libgcc` or `compiler-builtins`; tools/soft_float.rs),
/// NUL-terminated, for the cycle counter's report.
#[no_mangle]
pub static AHRS_BENCH_SOFTFLOAT: [u8; SOFTFLOAT.len() + 1] = {
    let mut b = [0u8; SOFTFLOAT.len() + 1];
    let s = SOFTFLOAT.as_bytes();
    let mut i = 0;
    while i < s.len() {
        b[i] = s[i];
        i += 1;
    }
    b
};
const SOFTFLOAT: &str = env!("AHRS_SOFTFLOAT_USED");

/// Euler output of the last output step, rad: roll, pitch, yaw. Written volatile so that the
/// conversion is part of every output step.
#[no_mangle]
pub static AHRS_BENCH_EULER: Global<[f32; 3]> = Global(UnsafeCell::new([0.0; 3]));

fn state() -> &'static mut State {
    // SAFETY: see `Global`; no two references are alive at once (each export takes one).
    unsafe { &mut *STATE.0.get() }
}

/// The last Euler output (roll, pitch, yaw), rad.
pub fn euler_out() -> [f32; 3] {
    // SAFETY: see `Global`.
    unsafe { core::ptr::read_volatile(AHRS_BENCH_EULER.0.get()) }
}

#[inline(always)]
fn sample(row: &[f32; 7]) -> ImuSample {
    ImuSample::new(row[0], Vec3::new(row[1], row[2], row[3]), Vec3::new(row[4], row[5], row[6]))
}

/// Filter updates per Euler output: the firmware's defaults, 50 Hz filter and 10 Hz output
/// (`filter.rate`, `output.rate` in `src/settings.rs`; `src/pipeline.rs` converts the
/// attitude only when an output is due).
pub const OUTPUT_DIVIDER: usize = 5;

impl State {
    /// The next motion sample, and whether its step ends with an output (every
    /// [`OUTPUT_DIVIDER`]-th of the lap, its last included).
    #[inline(always)]
    fn next_sample(&mut self) -> (ImuSample, bool) {
        let i = self.cursor % MOTION_LEN;
        self.cursor = (i + 1) % MOTION_LEN;
        let row = if self.moving { &MOVING[i] } else { &TRACE[INIT_LEN + i] };
        (sample(row), i % OUTPUT_DIVIDER == OUTPUT_DIVIDER - 1)
    }
}

#[inline(always)]
fn run<F: AttitudeFilter>(f: &mut F, s: &ImuSample, output: bool) -> u32 {
    let flags = f.update(s);
    if output {
        let Euler { roll, pitch, yaw } = f.euler();
        // SAFETY: see `Global`.
        unsafe { core::ptr::write_volatile(AHRS_BENCH_EULER.0.get(), [roll, pitch, yaw]) };
    }
    flags.0 as u32
}

macro_rules! step_fn {
    ($(#[$m:meta])* $name:ident, $variant:ident) => {
        $(#[$m])*
        #[no_mangle]
        #[inline(never)]
        pub extern "C" fn $name() -> u32 {
            let st = state();
            let (s, output) = st.next_sample();
            match &mut st.active {
                Active::$variant(f) => run(f, &s, output),
                _ => NOT_SELECTED,
            }
        }
    };
}

step_fn!(
    /// One EKF update on the next motion sample, and its Euler output when one is due.
    ahrs_bench_step_ekf,
    Ekf
);
step_fn!(
    /// One UKF update on the next motion sample, and its Euler output when one is due.
    ahrs_bench_step_ukf,
    Ukf
);
step_fn!(
    /// One SS-UKF update on the next motion sample, and its Euler output when one is due.
    ahrs_bench_step_ssukf,
    SsUkf
);
step_fn!(
    /// One complementary-filter update on the next motion sample, and its Euler output when one is due.
    ahrs_bench_step_cf,
    Cf
);
step_fn!(
    /// One gyro-only update on the next motion sample, and its Euler output when one is due.
    ahrs_bench_step_gyro,
    Gyro
);

/// One update of the selected filter on the next motion sample, and its Euler output when one
/// is due (every [`OUTPUT_DIVIDER`]-th); returns the update's flag bits, or [`NOT_SELECTED`].
#[no_mangle]
pub extern "C" fn ahrs_bench_step() -> u32 {
    match state().active {
        Active::Ekf(_) => ahrs_bench_step_ekf(),
        Active::Ukf(_) => ahrs_bench_step_ukf(),
        Active::SsUkf(_) => ahrs_bench_step_ssukf(),
        Active::Cf(_) => ahrs_bench_step_cf(),
        Active::Gyro(_) => ahrs_bench_step_gyro(),
        Active::None => NOT_SELECTED,
    }
}

fn init_window<F: AttitudeFilter>(f: &mut F) -> bool {
    for row in &TRACE[..INIT_LEN] {
        f.update(&sample(row));
    }
    f.is_initialised()
}

/// Select filter `id` (see [`FILTERS`]) with the default settings, run it through its
/// initialisation window on the trace's still part and rewind the motion part. Returns 0, or
/// [`BAD_ID`] / [`NOT_INITIALISED`].
#[no_mangle]
pub extern "C" fn ahrs_bench_select(id: u32) -> u32 {
    let s = Settings::default();
    let st = state();
    st.active = Active::None;
    st.cursor = 0;
    st.moving = false;
    // No output yet: the digest of the first steps (before the first output step) must not
    // fold the previous filter's last output (the emulation runs every filter in one machine,
    // the host one process per filter).
    // SAFETY: see `Global`.
    unsafe { core::ptr::write_volatile(AHRS_BENCH_EULER.0.get(), [0.0; 3]) };
    st.digest = FNV_OFFSET;
    let ok = match id {
        0 => {
            let mut f = Ekf::new(s);
            let ok = init_window(&mut f);
            st.active = Active::Ekf(f);
            ok
        }
        1 => {
            let mut f = Ukf::with_defaults();
            let ok = init_window(&mut f);
            st.active = Active::Ukf(f);
            ok
        }
        2 => {
            let mut f = SsUkf::with_defaults();
            let ok = init_window(&mut f);
            st.active = Active::SsUkf(f);
            ok
        }
        3 => {
            let mut f = Complementary::new(s, ComplementaryParams::default());
            let ok = init_window(&mut f);
            st.active = Active::Cf(f);
            ok
        }
        4 => {
            let mut f = GyroOnly::new(s);
            let ok = init_window(&mut f);
            st.active = Active::Gyro(f);
            ok
        }
        5 => {
            // One lap of the shaking first, not measured: the motion statistic has seen it.
            let mut f = Ekf::new(s);
            let ok = init_window(&mut f);
            for row in &MOVING {
                f.update(&sample(row));
            }
            st.active = Active::Ekf(f);
            st.moving = true;
            ok
        }
        _ => return BAD_ID,
    };
    if ok {
        0
    } else {
        NOT_INITIALISED
    }
}

/// FNV-1a (32 bit) offset basis and prime.
const FNV_OFFSET: u32 = 0x811c_9dc5;
const FNV_PRIME: u32 = 0x0100_0193;

/// Folds `word`'s four bytes into the FNV-1a digest `h`.
fn fold(h: u32, word: u32) -> u32 {
    word.to_le_bytes().iter().fold(h, |h, &b| (h ^ u32::from(b)).wrapping_mul(FNV_PRIME))
}

/// Folds the bit patterns of `values` into `h`.
fn fold_f32(h: u32, values: impl IntoIterator<Item = f32>) -> u32 {
    values.into_iter().fold(h, |h, v| fold(h, v.to_bits()))
}

/// Folds the selected filter's full state after a step into the running digest and returns
/// it: `flags` (the step's return value), the attitude quaternion, the gyro bias, the Euler
/// output and, for the EKF and the unscented filters, every element of the covariance — all as
/// bit patterns. Called after each step by the host and by `tools/cycles` on the emulated
/// Cortex-M3 (outside the measured step), so equal final digests mean every step's state was
/// bit-identical.
#[no_mangle]
pub extern "C" fn ahrs_bench_digest(flags: u32) -> u32 {
    let st = state();
    let mut h = fold(st.digest, flags);
    let euler = euler_out();
    let (q, b) = match &st.active {
        Active::Ekf(f) => (f.attitude(), f.gyro_bias()),
        Active::Ukf(f) => (f.attitude(), f.gyro_bias()),
        Active::SsUkf(f) => (f.attitude(), f.gyro_bias()),
        Active::Cf(f) => (f.attitude(), f.gyro_bias()),
        Active::Gyro(f) => (f.attitude(), f.gyro_bias()),
        Active::None => return st.digest,
    };
    h = fold_f32(h, [q.w, q.x, q.y, q.z, b.x, b.y, b.z]);
    h = fold_f32(h, euler);
    h = match &st.active {
        Active::Ekf(f) => fold_f32(h, f.covariance().m.iter().flatten().copied()),
        Active::Ukf(f) => fold_f32(h, f.covariance().iter().copied()),
        Active::SsUkf(f) => fold_f32(h, f.covariance().iter().copied()),
        _ => h,
    };
    st.digest = h;
    h
}

/// The default EKF, initialised on the trace's still part (`ahrs_bench_select(0)`).
#[no_mangle]
pub extern "C" fn ahrs_bench_init() {
    ahrs_bench_select(0);
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The measured path is the full one: every filter initialises on the still part, and on
    /// every motion sample (two laps, so the wrap-around too) the accelerometer is used and
    /// nothing is rejected, invalid or reset. The bench state is global, so one test only.
    #[test]
    fn every_step_takes_the_full_update_path() {
        let bad = Flags::ACCEL_GATED
            | Flags::ACCEL_KNOCK
            | Flags::ACCEL_INVALID
            | Flags::GYRO_INVALID
            | Flags::TIME_GAP
            | Flags::HEALTH_RESET
            | Flags::INITIALISING
            | Flags::REACQUIRE;
        for (id, name) in FILTERS.iter().enumerate() {
            assert_eq!(ahrs_bench_select(id as u32), 0, "{name} did not initialise");
            for k in 0..2 * MOTION_LEN {
                let f = ahrs_bench_step();
                assert_ne!(f, NOT_SELECTED);
                let f = Flags(f as u16);
                if *name != "gyro" {
                    assert!(f.contains(Flags::ACCEL_USED), "{name} step {k}: {f:?}");
                }
                assert!(!f.intersects(bad), "{name} step {k}: {f:?}");
                // The EKF takes the gentle lap raw and low-passes the shaking one: the two
                // paths of its tilt update (issue #35's time constant) are both measured.
                if let Active::Ekf(ekf) = &state().active {
                    let tau = ekf.time_constant();
                    match *name {
                        "ekf" => assert_eq!(tau, 0.0, "{name} step {k}"),
                        _ => assert!(tau > 1.0, "{name} step {k}: τ {tau} s"),
                    }
                }
            }
            // The estimate follows the trace's motion: pitch within ±20°.
            let e = euler_out();
            assert!(e.iter().all(|v| v.is_finite()), "{name}: {e:?}");
            assert!(e[1].abs() < 20f32.to_radians(), "{name}: {e:?}");
        }
        assert_eq!(ahrs_bench_select(99), BAD_ID);
        assert_eq!(ahrs_bench_step(), NOT_SELECTED);
    }
}
