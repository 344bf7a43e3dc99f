//! `cycle-bench`: every `ekf-core` filter behind a C ABI that any instruction-level tool
//! (an emulator, a debugger with the DWT cycle counter) can drive on the Cortex-M3.
//!
//! Exported, unmangled, `extern "C"`:
//! - `ahrs_bench_init()`: the default `Ekf` (same as `ahrs_bench_select(0)`);
//! - `ahrs_bench_select(id) -> u32`: a filter with the default settings (0 EKF, 1 UKF,
//!   2 SS-UKF, 3 complementary, 4 gyro-only, 5 the EKF on the lap with a hand's shaking), run
//!   through its initialisation window on the embedded trace's still part; returns 0, or
//!   `BAD_ID` / `NOT_INITIALISED`;
//! - `ahrs_bench_step() -> u32`: one full update of the selected filter on the next motion
//!   sample (for the EKF: prediction, accelerometer update with yaw-split, rest-block
//!   bookkeeping, health check) and, on every fifth (`OUTPUT_DIVIDER`: the firmware's 10 Hz
//!   output at its 50 Hz filter rate), its Euler output (stored in `AHRS_BENCH_EULER`);
//!   returns the update's `Flags` bits, or `NOT_SELECTED`;
//! - `ahrs_bench_step_<filter>()`: the same for one filter (never inlined: the tools take each
//!   filter's flash as the code statically reachable from it);
//! - `cal_*` (target only): hand-counted assembly routines that validate the cycle model
//!   (`tools/cycles/test_model.py`).
//!
//! `tools/cycles/cycle_count.py` (`scripts/cycle-count`) measures them; `docs/performance.md`
//! has the method and the figures. On the host the same code runs as a plain program (and its
//! tests check that every motion step takes the full update path).
#![cfg_attr(target_os = "none", no_std, no_main)]

pub mod bench;

#[cfg(target_os = "none")]
mod calibration;

/// Host: `cycle-bench` runs every filter over one lap of the motion trace and prints what it
/// did; `cycle-bench euler FILTER STEPS` prints the bits of the Euler output after `STEPS`
/// steps of `FILTER` (0–4), which `tools/cycles` compares with the emulated Cortex-M3.
#[cfg(not(target_os = "none"))]
fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if let [cmd, id, steps] = args.as_slice() {
        if cmd == "digest" {
            let (Ok(id), Ok(steps)) = (id.parse::<u32>(), steps.parse::<usize>()) else {
                eprintln!("usage: cycle-bench [euler|digest FILTER STEPS]");
                std::process::exit(2);
            };
            if bench::ahrs_bench_select(id) != 0 {
                eprintln!("cycle-bench: filter {id} did not initialise");
                std::process::exit(1);
            }
            let mut d = 0;
            for _ in 0..steps {
                d = bench::ahrs_bench_digest(bench::ahrs_bench_step());
            }
            println!("{d:08x}");
            return;
        }
        if cmd == "euler" {
            let (Ok(id), Ok(steps)) = (id.parse::<u32>(), steps.parse::<usize>()) else {
                eprintln!("usage: cycle-bench [euler FILTER STEPS]");
                std::process::exit(2);
            };
            if bench::ahrs_bench_select(id) != 0 {
                eprintln!("cycle-bench: filter {id} did not initialise");
                std::process::exit(1);
            }
            for _ in 0..steps {
                bench::ahrs_bench_step();
            }
            let e = bench::euler_out();
            println!("{:08x} {:08x} {:08x}", e[0].to_bits(), e[1].to_bits(), e[2].to_bits());
            return;
        }
    }
    if !args.is_empty() {
        eprintln!("usage: cycle-bench [euler FILTER STEPS]");
        std::process::exit(2);
    }
    for id in 0..bench::FILTERS.len() as u32 {
        if bench::ahrs_bench_select(id) != 0 {
            eprintln!("cycle-bench: filter {id} did not initialise");
            std::process::exit(1);
        }
        let used = (0..bench::MOTION_LEN)
            .filter(|_| bench::ahrs_bench_step() & bench::ACCEL_USED != 0)
            .count();
        println!(
            "{:<5} accelerometer used on {used}/{} steps; last euler {:?}",
            bench::FILTERS[id as usize],
            bench::MOTION_LEN,
            bench::euler_out()
        );
    }
}

#[cfg(target_os = "none")]
mod target {
    use core::hint::black_box;

    use crate::bench;

    /// Never run by the tools (they call the exported functions directly); it references every
    /// export so that the linker keeps them, and is what a board would run under a debugger.
    #[cortex_m_rt::entry]
    fn main() -> ! {
        let cal: [unsafe extern "C" fn(u32) -> u32; 6] = black_box([
            crate::calibration::cal_alu,
            crate::calibration::cal_loop,
            crate::calibration::cal_loop_far,
            crate::calibration::cal_wide,
            crate::calibration::cal_mem,
            crate::calibration::cal_lit_mul,
        ]);
        let steps: [extern "C" fn() -> u32; 5] = black_box([
            bench::ahrs_bench_step_ekf,
            bench::ahrs_bench_step_ukf,
            bench::ahrs_bench_step_ssukf,
            bench::ahrs_bench_step_cf,
            bench::ahrs_bench_step_gyro,
        ]);
        let scratch = [0u32; 4];
        for f in cal {
            // SAFETY: the routines only touch registers and the 16 bytes at their argument.
            black_box(unsafe { f(scratch.as_ptr() as u32) });
        }
        // Through opaque pointers, so the exports stay out-of-line functions of their own.
        let init: extern "C" fn() = black_box(bench::ahrs_bench_init);
        let select: extern "C" fn(u32) -> u32 = black_box(bench::ahrs_bench_select);
        let step: extern "C" fn() -> u32 = black_box(bench::ahrs_bench_step);
        let digest: extern "C" fn(u32) -> u32 = black_box(bench::ahrs_bench_digest);
        black_box(&bench::AHRS_BENCH_SOFTFLOAT);
        init();
        loop {
            for id in 0..bench::FILTERS.len() as u32 {
                black_box(select(black_box(id)));
                for _ in 0..bench::MOTION_LEN {
                    black_box(digest(step()));
                }
                black_box(steps[id as usize]());
            }
        }
    }

    #[panic_handler]
    fn panic(_: &core::panic::PanicInfo) -> ! {
        cortex_m::asm::udf()
    }
}
